"""Teacher to student against PPO from scratch on the student's view: frames and seconds to 90 % of the teacher.

    OMP_NUM_THREADS=1 python benchmarks/studies/distill_vs_scratch.py                  # CartPole, seeds 1 2 3
    OMP_NUM_THREADS=1 python benchmarks/studies/distill_vs_scratch.py --seeds 1 --csv-dir benchmarks/results/distill
    OMP_NUM_THREADS=1 python benchmarks/studies/distill_vs_scratch.py --task halfcheetah --seeds 1 --max-frames 1000000

The teacher's return is measured first: its checkpoint played ``--games`` games, deterministic, on the
full observation. The target is ``--fraction`` (0.9) of it. Then, one run at a time in this process:

- ``distill``: ``rlchain/configs/distill_<task>_lstm.yaml`` (an LSTM student on positions only, DAgger
  from the teacher);
- ``scratch``: PPO on the same view (``obs_groups.student``, ``policy: student``) with the same network;
  CartPole: the PPO settings of ``ppo_cartpole_masked_velocity_rnn.yaml`` (tuned for that memory task),
  HalfCheetah: ``ppo_halfcheetah.yaml``'s (the teacher's) with the student's network.

Both stop at the target (``score_to_win``: the mean return of the last 100 episodes the student played
alone) or at ``--max-frames``. Printed: a row per run and the median per method, frames (independent of
the machine's load) and seconds (not: the machine may be shared). The teacher's own PPO training is not
counted in the distill rows (it is the privileged first stage; nn/cartpole.pth ships trained).
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)

from rlchain import Runner  # noqa: E402
from rlchain.inference.player import Player  # noqa: E402
from rlchain.training.events import Callback  # noqa: E402

CONFIGS = os.path.join(ROOT, "rlchain", "configs")
TASKS = {
    "cartpole": {
        "teacher": os.path.join(ROOT, "rlchain", "checkpoints", "cartpole.pth"),
        "teacher_config": os.path.join(CONFIGS, "ppo_cartpole.yaml"),
        "distill": (os.path.join(CONFIGS, "distill_cartpole_lstm.yaml"), ["params.config.full_experiment_name=null"]),
        "scratch": (os.path.join(CONFIGS, "ppo_cartpole_masked_velocity_rnn.yaml"),
                    ["params.config.env_name=CartPole-v1", "params.config.obs_groups={student: [0, 2], "
                                                           "policy: student}"]),
    },
    "halfcheetah": {
        "teacher": os.path.join(ROOT, "rlchain", "checkpoints", "halfcheetah_teacher.pth"),
        "teacher_config": os.path.join(CONFIGS, "ppo_halfcheetah.yaml"),
        "distill": (os.path.join(CONFIGS, "distill_halfcheetah_lstm.yaml"),
                    ["params.config.full_experiment_name=null"]),
        # PPO with the student's network (the distill config's) on the student's view, noise left out
        "scratch": (os.path.join(CONFIGS, "ppo_halfcheetah.yaml"),
                    ["params.config.obs_groups={student: ['0:8'], policy: student}",
                     "params.network.mlp={units: [128, 64], activation: elu, initializer: {name: default}}",
                     "params.network.rnn={name: lstm, units: 128, layers: 1, before_mlp: True, concat_input: True, "
                     "layer_norm: True}", "params.config.seq_length=16"]),
    },
}


class Curve(Callback):
    """(seconds since training started, frames, mean reward) after every epoch."""

    def __init__(self) -> None:
        self.points: list[tuple[float, int, float]] = []
        self.start = 0.0

    def on_train_start(self, ctx) -> None:
        self.start = time.monotonic()

    def on_epoch_end(self, ctx, stats, episodes) -> None:
        if episodes is not None:
            self.points.append((time.monotonic() - self.start, ctx.state.frames, episodes["reward"]))


def teacher_return(task: dict, games: int) -> float:
    """The teacher checkpoint's mean return over ``games`` deterministic games on the full observation."""
    params = Runner().load(task["teacher_config"], ["params.config.player.print_stats=False"]).params
    player = Player(params, task["teacher"])
    try:
        return player.play(games=games, deterministic=True, quiet=True).mean_reward
    finally:
        player.close()


def run(config: str, overrides: list[str], seed: int, target: float, max_frames: int, train_dir: str) -> dict:
    """One training run until ``target`` or ``max_frames``; frames and seconds when it reached the target."""
    curve = Curve()
    runner = Runner().load(config, [*overrides, f"params.seed={seed}", f"params.config.score_to_win={target}",
                                    f"params.config.max_frames={max_frames}", "params.config.max_epochs=-1",
                                    f"params.config.train_dir={train_dir}", "params.config.print_stats=False",
                                    "params.torch_threads=1"])
    runner.train(callbacks=[curve])
    hit = next(((t, f) for t, f, r in curve.points if r >= target), None)
    return {"seed": seed, "reached": hit is not None, "seconds": hit[0] if hit else None,
            "frames": hit[1] if hit else None, "last_frames": curve.points[-1][1] if curve.points else 0,
            "best": max((r for _, _, r in curve.points), default=float("nan")), "points": curve.points}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--task", default="cartpole", choices=sorted(TASKS))
    p.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    p.add_argument("--methods", nargs="+", default=["distill", "scratch"], choices=["distill", "scratch"])
    p.add_argument("--fraction", type=float, default=0.9, help="of the teacher's return")
    p.add_argument("--games", type=int, default=20, help="games the teacher's return is measured over")
    p.add_argument("--max-frames", type=int, default=600_000)
    p.add_argument("--csv-dir", default=None, help="write each run's curve (seconds, frames, reward) here")
    p.add_argument("--plot", default=None, help="write the curves against frames and seconds to this PNG")
    p.add_argument("--replot", action="store_true", help="no training: plot and tabulate the curves of --csv-dir")
    args = p.parse_args()
    task = TASKS[args.task]
    teacher = teacher_return(task, args.games)
    target = args.fraction * teacher
    print(f"{args.task}: teacher return {teacher:.1f} over {args.games} games; target {target:.1f} "
          f"({args.fraction:.0%})", flush=True)
    rows: dict[str, list[dict]] = {m: [] for m in args.methods}
    if args.replot:
        for method in args.methods:
            for seed in args.seeds:
                with open(os.path.join(args.csv_dir, f"{args.task}_{method}_seed{seed}.csv")) as fh:
                    points = [(float(t), int(f), float(r)) for t, f, r in list(csv.reader(fh))[1:]]
                hit = next(((t, f) for t, f, r in points if r >= target), None)
                rows[method].append({"seed": seed, "reached": hit is not None, "seconds": hit and hit[0],
                                     "frames": hit and hit[1], "points": points})
        args.methods = []  # nothing to train
    with tempfile.TemporaryDirectory() as tmp:
        for method in args.methods:
            config, overrides = task[method]
            for seed in args.seeds:
                r = run(config, overrides, seed, target, args.max_frames, os.path.join(tmp, f"{method}{seed}"))
                rows[method].append(r)
                done = f"{r['frames']:>8} frames {r['seconds']:7.1f} s" if r["reached"] else \
                    f"not reached in {r['last_frames']} frames (best {r['best']:.1f})"
                print(f"  {method:8s} seed {seed}: {done}", flush=True)
                if args.csv_dir:
                    os.makedirs(args.csv_dir, exist_ok=True)
                    with open(os.path.join(args.csv_dir, f"{args.task}_{method}_seed{seed}.csv"), "w",
                              newline="") as fh:
                        w = csv.writer(fh)
                        w.writerow(["seconds", "frames", "mean_reward"])
                        w.writerows((f"{t:.2f}", f, f"{rew:.2f}") for t, f, rew in r["points"])
    if args.plot:
        plot(rows, target, teacher, args.task, args.plot)
    print(f"\n| method | seeds reaching {target:.0f} | median frames | median seconds (loaded machine) |")
    print("|---|---|---|---|")
    for method, runs in rows.items():
        hit = [r for r in runs if r["reached"]]
        frames = statistics.median(r["frames"] for r in hit) if hit else float("nan")
        seconds = statistics.median(r["seconds"] for r in hit) if hit else float("nan")
        print(f"| {method} | {len(hit)}/{len(runs)} | {frames:,.0f} | {seconds:.1f} |")


def plot(rows: dict[str, list[dict]], target: float, teacher: float, task: str, path: str) -> None:
    """Mean reward against frames and against seconds, one line per run, the target and the teacher."""
    import matplotlib  # optional: matplotlib (the plot only)
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    colors = {"distill": "tab:blue", "scratch": "tab:orange"}
    for method, runs in rows.items():
        for i, r in enumerate(runs):
            t, f, rew = zip(*r["points"]) if r["points"] else ((), (), ())
            label = f"{method} ({len(runs)} seeds)" if i == 0 else None
            axes[0].plot(f, rew, color=colors[method], alpha=0.8, label=label)
            axes[1].plot(t, rew, color=colors[method], alpha=0.8, label=label)
    for ax, xlabel in zip(axes, ("env frames", "seconds (shared, loaded 2-core machine)")):
        ax.axhline(teacher, color="gray", ls=":", label="teacher")
        ax.axhline(target, color="gray", ls="--", label="90 % of the teacher")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("mean return (student alone)")
    axes[0].legend(loc="lower right")
    fig.suptitle(f"{task}: distilled student vs PPO from scratch on the student's view")
    fig.tight_layout()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fig.savefig(path, dpi=80)


if __name__ == "__main__":
    main()
