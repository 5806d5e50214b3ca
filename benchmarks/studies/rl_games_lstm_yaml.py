"""rl_games' own masked-velocity LSTM YAML, as written, on rlchain: frames to each score, per seed.

    python benchmarks/studies/rl_games_lstm_yaml.py                      # seeds 5 1 2, one torch thread
    python benchmarks/studies/rl_games_lstm_yaml.py --seeds 5 --max-frames 800000

The YAML (benchmarks/rl_games_configs/ppo_cartpole_masked_velocity_rnn.yaml: 2-layer LSTM with layer norm,
lr 1e-4, 16 envs x 256 steps) trains unchanged but for the seed, one torch thread (so the machine's load
cannot change the run), a stop at 450 and a frame cap. Prints, per seed, the frames at which the mean
reward first reached each of ``--scores`` (a feedforward policy on this env stays under 200), and the
wall time.
"""

from __future__ import annotations

import argparse
import glob
import os
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain first
    sys.path.insert(0, ROOT)

from rlchain import Runner  # noqa: E402

CONFIG = os.path.join(ROOT, "benchmarks", "rl_games_configs", "ppo_cartpole_masked_velocity_rnn.yaml")


def frames_to_scores(run_dir: str, scores: list[float]) -> dict[float, int | None]:
    """The first logged frame count at which ``rewards/step`` reached each score (None: never)."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(glob.glob(os.path.join(run_dir, "**", "events*"), recursive=True)[0])
    events.Reload()
    curve = events.Scalars("rewards/step")
    return {s: next((e.step for e in curve if e.value >= s), None) for s in scores}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[5, 1, 2])
    parser.add_argument("--scores", type=float, nargs="+", default=[200, 300, 350, 400, 450])
    parser.add_argument("--max-frames", type=int, default=1_600_000)
    args = parser.parse_args()
    for seed in args.seeds:
        train_dir = tempfile.mkdtemp(prefix="rlg_lstm_")
        overrides = [f"params.config.train_dir={train_dir}", "params.config.print_stats=false", f"params.seed={seed}",
                     "params.torch_threads=1", "params.update_threads=1", "params.config.score_to_win=450",
                     f"params.config.max_frames={args.max_frames}"]
        start = time.time()
        result = Runner().load(CONFIG, overrides).train()
        reached = frames_to_scores(result.run_dir, args.scores)
        shown = ", ".join(f"{s:g}: {f if f is not None else '-'}" for s, f in reached.items())
        print(f"seed {seed}: frames to score {{{shown}}}; stopped at {result.frames} frames "
              f"({result.stop_reason}), {time.time() - start:.0f} s", flush=True)


if __name__ == "__main__":
    main()
