"""Per-epoch timing from the TensorBoard logs of runs kept by ``compare.py --keep``.

rlchain and rl_games both write, once per epoch, ``performance/step_inference_rl_update_fps``
(frames of the epoch / (rollout + update seconds)), ``performance/rl_update_time`` (update
seconds) and the rollout seconds (rlchain: ``performance/step_time``, env steps plus inference;
rl_games: ``performance/step_inference_time``, the same span; its ``step_time`` is env stepping
alone). This prints their means over the epochs after the first (the first holds start-up
costs), so runs too short for ``rewards/step`` events (Atari: no game ends in the first
epochs) still compare::

    python benchmarks/peers/epoch_timing.py rlchain=/tmp/bench_rlchain_x rl_games=/tmp/bench_rl_games_y
"""

import argparse
import glob
import os
import sys

ROLLOUT_TAGS = ("performance/step_inference_time", "performance/step_time")
"""The rollout-seconds tag, first one present wins (rl_games writes both; rlchain the second)."""


def scalars(workdir):
    """{tag: [(step, value), ...]} of the first run under ``workdir/runs``."""
    from tensorboard.backend.event_processing import event_accumulator as ea

    paths = sorted(glob.glob(os.path.join(workdir, "runs", "**", "events.out.tfevents.*"), recursive=True))
    if not paths:
        raise SystemExit(f"no TensorBoard events under {workdir}/runs")
    acc = ea.EventAccumulator(os.path.dirname(paths[0]), size_guidance={ea.SCALARS: 0})
    acc.Reload()
    return {tag: [(e.step, e.value) for e in acc.Scalars(tag)] for tag in acc.Tags()["scalars"]}


def summary(workdir):
    """Epochs logged, last frame count and the means (epochs 2..N) of fps, rollout and update seconds."""
    tags = scalars(workdir)
    fps = [v for _, v in tags["performance/step_inference_rl_update_fps"]]
    update = [v for _, v in tags["performance/rl_update_time"]]
    rollout_tag = next(t for t in ROLLOUT_TAGS if t in tags)
    rollout = [v for _, v in tags[rollout_tag]]

    def mean(xs):
        xs = xs[1:] if len(xs) > 1 else xs
        return sum(xs) / len(xs)

    return {"epochs": len(fps), "last_frames": tags["performance/step_inference_rl_update_fps"][-1][0],
            "fps": mean(fps), "rollout_s": mean(rollout), "update_s": mean(update)}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+", help="NAME=WORKDIR (a compare.py --keep temp dir)")
    args = p.parse_args(argv)
    rows = {}
    for item in args.runs:
        name, _, workdir = item.partition("=")
        rows[name] = summary(workdir)
    keys = ("epochs", "last_frames", "fps", "rollout_s", "update_s")
    print(f"{'run':<12}" + "".join(f"{k:>14}" for k in keys))
    for name, row in rows.items():
        cells = "".join(f"{row[k]:>14.1f}" if isinstance(row[k], float) else f"{row[k]:>14}" for k in keys)
        print(f"{name:<12}{cells}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
