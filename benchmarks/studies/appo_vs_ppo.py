"""APPO (local runner threads) against PPO on the same CartPole / Pendulum settings: reward against time.

    python benchmarks/studies/appo_vs_ppo.py                                  # both tasks, 3 seeds, ~5 min
    python benchmarks/studies/appo_vs_ppo.py --tasks cartpole --seeds 1 2 --budget 30

The pairs are ``rlchain/configs/ppo_<task>.yaml`` and ``appo_<task>.yaml``: the same network and PPO
settings (lr, adaptive KL, clip, minibatch, mini_epochs, num_actors, horizon_length), the appo one
without ``tau`` (V-trace has none) and with its runners (``env_runners``, ``appo``). Runs go one at a
time in this process, each until the config's ``score_to_win`` or ``--budget`` seconds. Printed:
time and frames to the score (mean over the seeds that reached it, with how many did), and the mean
reward at fixed seconds (a run that stopped at the score counts with its last value afterwards).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)

from benchmarks.common import cpu_model  # noqa: E402
from rlchain import Runner  # noqa: E402
from rlchain.training.events import Callback  # noqa: E402


class Curve(Callback):
    """(seconds since training started, frames, mean reward) after every epoch; stops at the budget."""

    def __init__(self, budget: float) -> None:
        self.budget, self.points, self.start = budget, [], None

    def on_train_start(self, ctx) -> None:
        self.start = time.monotonic()

    def on_epoch_end(self, ctx, stats, episodes) -> None:
        if episodes is not None:
            self.points.append((time.monotonic() - self.start, ctx.state.frames, episodes["reward"]))
        if time.monotonic() - self.start > self.budget:
            ctx.request_stop("budget")


def reward_at(points: list, seconds: float) -> float | None:
    before = [r for t, _, r in points if t <= seconds]
    return before[-1] if before else None


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--tasks", nargs="+", default=["cartpole", "pendulum"], choices=["cartpole", "pendulum"])
    p.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    p.add_argument("--budget", type=float, default=60.0, help="seconds per run at most")
    p.add_argument("--overrides", nargs="*", default=["params.torch_threads=1"],
                   help="for both algos; default one torch thread: PPO's default 2-thread update is many times "
                        "slower on 2 cores that other jobs load (appo's update keeps torch_threads anyway)")
    args = p.parse_args()
    print(f"CPU: {cpu_model()}, {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f} (start); "
          f"overrides {' '.join(args.overrides) or 'none'}")
    marks = {"cartpole": [2, 4, 6, 8, 10, 15], "pendulum": [5, 10, 15, 20, 30, 45]}
    for task in args.tasks:
        rows = {}
        for algo in ("ppo", "appo"):
            runs = []
            for seed in args.seeds:
                curve = Curve(args.budget)
                with tempfile.TemporaryDirectory() as tmp:
                    result = Runner().load(os.path.join(ROOT, "rlchain", "configs", f"{algo}_{task}.yaml"),
                                           [f"params.config.train_dir={tmp}", "params.config.print_stats=false",
                                            f"params.seed={seed}", *args.overrides]).train(callbacks=[curve])
                won = result.stop_reason.startswith("score_to_win")
                runs.append((curve.points, won, result))
                print(f"{task} {algo} seed {seed}: {result.stop_reason} at {curve.points[-1][0]:.1f} s, "
                      f"{result.frames} frames, reward {result.mean_reward:.1f} (load "
                      f"{os.getloadavg()[0]:.1f})", flush=True)
            rows[algo] = runs
        print(f"\n{task}: mean reward at seconds of training ({len(args.seeds)} seeds)\n")
        print("| algo | time to score | frames to score | " + " | ".join(f"{s} s" for s in marks[task]) + " |")
        print("|---|---|---|" + "---|" * len(marks[task]))
        for algo, runs in rows.items():
            won = [(pts[-1][0], res.frames) for pts, ok, res in runs if ok]
            when = f"{statistics.mean(t for t, _ in won):.1f} s ({len(won)}/{len(runs)})" if won else "not reached"
            frames = f"{statistics.mean(f for _, f in won):,.0f}" if won else "-"
            cells = []
            for s in marks[task]:
                values = [reward_at(pts, s) for pts, _, _ in runs]
                values = [v for v in values if v is not None]
                cells.append(f"{statistics.mean(values):.0f}" if values else "-")
            print(f"| {algo} | {when} | {frames} | " + " | ".join(cells) + " |")
        print(flush=True)
    print(f"load average {os.getloadavg()[0]:.2f} (end)")


if __name__ == "__main__":
    main()
