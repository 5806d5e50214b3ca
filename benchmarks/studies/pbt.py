"""PBT against fixed-config seeds on the same frames: does the population's schedule pay?

    python benchmarks/studies/pbt.py                               # HalfCheetah-v4 (envpool), 4 members, 2 at once
    python benchmarks/studies/pbt.py --epochs 40 --num-actors 32 --horizon 64 --out /tmp/pbt

Both arms run on Ray Tune through ``--tune``'s own code (rlchain.tuning.ray_search.fit) in one local
Ray session, from the same starting config (``benchmarks/rl_games_configs/halfcheetah_envpool.yaml``
with the batch shrunk by --num-actors / --horizon / --minibatch so the run fits a small CPU budget):

- fixed: ``--members`` trials of the starting config (FIFO), seeds base+0..N-1;
- pbt: ``--members`` trials that start from the same values; every --interval epochs the bottom
  quarter loads a top trial's checkpoint and perturbs ``kl_threshold`` (the adaptive learning rate's
  target) and ``e_clip`` live.

Every member ends at epoch --epochs in both arms, but a PBT member that copies a donor takes the
donor's epochs and frames (it skips ahead, or re-runs epochs from an older checkpoint), so the PBT
arm simulates a different number of frames: the script counts the frames each arm really simulated
and compares the arms at the same simulated frames too. Reported: every member's reward against its
frames, the best and median member against the arm's simulated frames and against wall time,
plotted (matplotlib) and written as JSON. Wall times move with the machine's load: the CPU model
and the load average are printed and stored.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import sys
import tempfile
import time

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)

from benchmarks.common import DOCS_IMG, cpu_model, results_dir  # noqa: E402
from rlchain.tuning import ray_search  # noqa: E402
from rlchain.tuning.common import load_search  # noqa: E402
from rlchain.tuning.spec import RaySpec  # noqa: E402

CONFIG = os.path.join(ROOT, "benchmarks", "rl_games_configs", "halfcheetah_envpool.yaml")


def search_file(folder: str, name: str, args: argparse.Namespace, start: dict[str, float], pbt: bool) -> str:
    overrides = [f"params.config.num_actors={args.num_actors}", f"params.config.horizon_length={args.horizon}",
                 f"params.config.minibatch_size={args.minibatch}", "params.config.save_best_after=100000",
                 f"params.config.env_config.num_threads={args.cpus}", f"params.config.games_to_track={args.games}"]
    search: dict = {"base": args.config, "backend": "ray", "metric": "mean_reward", "trials": args.members,
                    "concurrent": args.concurrent, "resources": {"cpus": args.cpus},
                    "max_epochs_per_trial": args.epochs, "overrides": overrides, "seed": args.seed,
                    "checkpoint_epochs": args.interval, "max_failures": 0,
                    "params": {key: {"type": "categorical", "choices": [value]} for key, value in start.items()}}
    if pbt:
        search.update(scheduler="pbt", pbt={
            "interval_epochs": args.interval, "quantile": 0.25, "resample_probability": 0.25,
            "mutations": {"params.config.kl_threshold": {"type": "loguniform", "low": 0.002, "high": 0.05},
                          "params.config.e_clip": {"type": "uniform", "low": 0.1, "high": 0.3}}})
    else:
        search.update(scheduler="fifo", searcher="grid")
    path = os.path.join(folder, f"{name}.yaml")
    with open(path, "w", encoding="utf-8") as fh:
        yaml.safe_dump(search, fh)
    return path


def curves(outcome: ray_search.SearchOutcome, t0: float, frames_per_epoch: int) -> dict:
    """Per member: every epoch it reported, in order ([epoch, member frames, mean reward, seconds since
    the arm started]); an exploit makes a member jump to its donor's epoch (its frames are then the
    donor's), an older checkpoint makes it re-run epochs. ``arm``: the arm's best and median member
    reward after each epoch any member ran, against the frames the arm really simulated so far."""
    members, rows = [], []
    for i, result in enumerate(outcome.results):
        frame = result.metrics_dataframe
        member = []
        for _, row in frame.iterrows():
            reward = float(row["mean_reward"])
            entry = [int(row["epoch"]), int(row["frames"]), reward, float(row["timestamp"]) - t0]
            member.append(entry)
            rows.append((entry[3], i, reward))
        members.append(member)
    latest: dict[int, float] = {}
    arm = []
    for n, (seconds, i, reward) in enumerate(sorted(rows, key=lambda r: r[0]), start=1):
        latest[i] = reward
        known = [v for v in latest.values() if math.isfinite(v)]  # -inf until a member's first episode
        if known:
            arm.append([n * frames_per_epoch, max(known), statistics.median(known), seconds])
    return {"members": members, "arm": arm, "epochs_simulated": len(rows)}


def at_frames(arm: list, frames: int) -> list:
    """The arm's [frames, best, median, seconds] once it had simulated ``frames``."""
    for point in arm:
        if point[0] >= frames:
            return point
    return arm[-1]


def summary(result: dict, epochs: int) -> dict:
    out = {}
    for name in ("fixed", "pbt"):
        arm = result[name]
        finals = [m[-1][2] for m in arm["members"] if m and m[-1][0] == epochs]
        out[name] = {"best": max(finals), "median": statistics.median(finals), "finals": finals,
                     "epochs_simulated": arm["epochs_simulated"]}
    # the same frames: each arm when the one that simulated fewer frames ended
    frames = min(result["fixed"]["arm"][-1][0], result["pbt"]["arm"][-1][0])
    out["same_frames"] = {"frames": frames, **{name: at_frames(result[name]["arm"], frames)[1:3]
                                               for name in ("fixed", "pbt")}}
    return out


def plot(result: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.2))
    for arm, color in (("fixed", "tab:blue"), ("pbt", "tab:red")):
        for i, member in enumerate(result[arm]["members"]):
            points = [r for r in member if math.isfinite(r[2])]
            label = f"{arm}: members" if i == 0 else None
            axes[0].plot([r[1] for r in points], [r[2] for r in points], color=color, alpha=0.5, label=label)
        curve = result[arm]["arm"]
        axes[1].plot([p[0] for p in curve], [p[1] for p in curve], color=color, label=f"{arm}: best member")
        axes[1].plot([p[0] for p in curve], [p[2] for p in curve], color=color, ls="--", label=f"{arm}: median")
        axes[2].plot([p[3] for p in curve], [p[1] for p in curve], color=color, label=f"{arm}: best member")
        axes[2].plot([p[3] for p in curve], [p[2] for p in curve], color=color, ls="--", label=f"{arm}: median")
    axes[0].set_xlabel("frames per member (an exploit takes the donor's)")
    axes[1].set_xlabel("frames the arm simulated (all members)")
    axes[2].set_xlabel("wall seconds since the arm started (2 at once, shared CPU)")
    for ax in axes:
        ax.set_ylabel("mean reward")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(f"PBT vs fixed config: {os.path.basename(result['config'])}, {result['cpu']}")
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--config", default=CONFIG)
    p.add_argument("--members", type=int, default=4)
    p.add_argument("--concurrent", type=int, default=2)
    p.add_argument("--cpus", type=int, default=1, help="CPUs per trial (torch and envpool threads)")
    p.add_argument("--epochs", type=int, default=150)
    p.add_argument("--interval", type=int, default=10, help="PBT perturbation interval (epochs)")
    p.add_argument("--num-actors", type=int, default=16)
    p.add_argument("--horizon", type=int, default=128)
    p.add_argument("--minibatch", type=int, default=1024)
    p.add_argument("--games", type=int, default=16, help="games_to_track: the mean reward of the latest episodes")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=None, help="writes <out>.json and <out>.png (default: benchmarks/results/pbt/pbt)")
    p.add_argument("--docs", action="store_true", help="also copy the PNG to docs/img/curves/, where the docs show it")
    p.add_argument("--plot-only", action="store_true", help="redo the summary and plot from <out>.json")
    args = p.parse_args(argv)
    if args.out is None:
        args.out = os.path.join(results_dir("pbt"), "pbt")
    if args.plot_only:
        with open(args.out + ".json", encoding="utf-8") as fh:
            return report(json.load(fh), args)
    import ray

    raw = yaml.safe_load(open(args.config, encoding="utf-8"))["params"]["config"]
    start = {"params.config.kl_threshold": float(raw["kl_threshold"]), "params.config.e_clip": float(raw["e_clip"])}
    result: dict = {"config": os.path.relpath(args.config, ROOT), "cpu": cpu_model(), "cores": os.cpu_count(),
                    "args": {**vars(args), "config": os.path.relpath(args.config, ROOT),
                             "out": os.path.relpath(args.out, ROOT)},
                    "load_before": os.getloadavg()}
    started = ray_search._connect(ray, RaySpec(num_cpus=args.concurrent * args.cpus))
    try:
        with tempfile.TemporaryDirectory() as folder:
            for arm in ("fixed", "pbt"):
                spec = load_search(search_file(folder, arm, args, start, pbt=arm == "pbt"))
                t0 = time.time()
                outcome = ray_search.fit(spec, output=os.path.join(folder, arm, "best.yaml"),
                                         train_dir=os.path.join(folder, arm, "runs"))
                result[arm] = {**curves(outcome, t0, args.num_actors * args.horizon), "seconds": time.time() - t0,
                               "exploits": len(outcome.exploits)}
                if outcome.schedule_path:
                    with open(outcome.schedule_path, encoding="utf-8") as fh:
                        result[arm]["winner_schedule"] = yaml.safe_load(fh)["params"]["config"]["hyperparam_schedule"]
    finally:
        if started:
            ray.shutdown()
    result["load_after"] = os.getloadavg()
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out + ".json", "w", encoding="utf-8") as fh:  # the raw curves first
        json.dump(result, fh)
    return report(result, args)


def report(result: dict, args: argparse.Namespace) -> int:
    """Summary table, JSON and plot of a finished run."""
    args = argparse.Namespace(**{**result["args"], "out": args.out, "docs": args.docs})
    result["summary"] = summary(result, args.epochs)
    with open(args.out + ".json", "w", encoding="utf-8") as fh:
        json.dump(result, fh)
    plot(result, args.out + ".png")
    if args.docs:  # MkDocs serves only docs/: the page shows this copy
        shutil.copyfile(args.out + ".png", os.path.join(DOCS_IMG, "curves", os.path.basename(args.out) + ".png"))
    frames = args.epochs * args.num_actors * args.horizon
    print(f"\n{os.path.basename(args.config)}: {args.members} members x {args.epochs} epochs x "
          f"{args.num_actors * args.horizon} frames ({frames} per member); CPU {result['cpu']}, "
          f"load {result['load_before'][0]:.1f} -> {result['load_after'][0]:.1f}")
    print(f"{'arm':6} {'best':>8} {'median':>8} {'epochs run':>10} {'seconds':>8}  finals (every member at epoch "
          f"{args.epochs})")
    for arm in ("fixed", "pbt"):
        s = result["summary"][arm]
        print(f"{arm:6} {s['best']:8.1f} {s['median']:8.1f} {s['epochs_simulated']:10d} "
              f"{result[arm]['seconds']:8.0f}  {', '.join(f'{v:.0f}' for v in s['finals'])}")
    same = result["summary"]["same_frames"]
    print(f"at the same simulated frames ({same['frames']}): fixed best {same['fixed'][0]:.1f} median "
          f"{same['fixed'][1]:.1f}; pbt best {same['pbt'][0]:.1f} median {same['pbt'][1]:.1f}")
    print(f"pbt exploits: {result['pbt']['exploits']}; winner's schedule: {result['pbt'].get('winner_schedule')}")
    print(f"wrote {args.out}.json and {args.out}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
