"""Training fps with 1 process and with N torchrun processes (multi_gpu, gloo on CPU), side by side.

    python benchmarks/scaling/distributed_scaling.py                          # the default configs below
    python benchmarks/scaling/distributed_scaling.py --configs ppo_pendulum.yaml --epochs 10 --repeats 3
    python benchmarks/scaling/distributed_scaling.py --nprocs 2 4 --json out.json

Each run is a real ``runner.py --train`` subprocess: ``python runner.py`` for 1 process (with the
Runner's default torch threads; ``--threads-row`` adds one with ``torch_threads`` = all cores), ``torchrun
--standalone --nproc_per_node=N runner.py ... multi_gpu=True`` for N processes. The config is used
as written, so (as in rl_games) every process steps ``num_actors`` envs: N processes collect N
times the frames per epoch. fps = frames of all ranks between the end of epoch ``--warmup`` and
the last epoch, divided by the wall time between them (rank 0's clock, written by the
``EpochClock`` callback), so start-up and the first epochs do not count. Runs of one config are
interleaved over ``--repeats`` and the median is printed. The load average is printed as well:
other processes on the machine skew every number.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from typing import Any

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)

from rlchain.training.events import Callback  # noqa: E402

CLOCK_ENV = "RLCHAIN_BENCH_CLOCK"
DEFAULT_CONFIGS = ["ppo_cartpole.yaml", "ppo_pendulum.yaml", "ppo_halfcheetah.yaml"]


class EpochClock(Callback):
    """Callback (rank 0 only): appends ``[time, frames]`` per epoch to the JSON file $RLCHAIN_BENCH_CLOCK."""

    def __init__(self) -> None:
        self.marks: list[list[float]] = []

    def on_epoch_end(self, ctx: Any, stats: dict, episodes: dict | None) -> None:
        state = ctx.state
        if not state.is_main:
            return
        self.marks.append([time.perf_counter(), state.frames])
        with open(os.environ[CLOCK_ENV], "w") as fh:
            json.dump(self.marks, fh)


def run_once(config: str, nproc: int, threads: int | None, epochs: int, warmup: int, folder: str,
             timeout: float) -> dict[str, Any]:
    """One training run; returns fps after warm-up, frames per epoch and the wall time."""
    clock = os.path.join(folder, f"clock_{nproc}_{threads}_{time.monotonic_ns()}.json")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([ROOT, os.environ.get("PYTHONPATH", "")]),
               **{CLOCK_ENV: clock})
    overrides = [f"params.config.max_epochs={warmup + epochs}", "params.config.score_to_win=1e12",
                 "params.config.save_best_after=1000000", f"params.config.train_dir={folder}/runs",
                 'params.config.callbacks=["benchmarks.scaling.distributed_scaling:EpochClock"]',
                 "params.config.print_stats=false"]
    if threads is not None:
        overrides.append(f"params.torch_threads={threads}")
    args = ["--train", "--file", os.path.join(ROOT, "rlchain", "configs", config), *overrides]
    if nproc == 1:
        cmd = [sys.executable, os.path.join(ROOT, "runner.py"), *args]
    else:
        cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nnodes=1",
               f"--nproc_per_node={nproc}", os.path.join(ROOT, "runner.py"), *args, "params.config.multi_gpu=True"]
    start = time.perf_counter()
    out = subprocess.run(cmd, cwd=folder, env=env, capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - start
    if out.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{out.stderr[-2000:]}")
    with open(clock) as fh:
        marks = json.load(fh)
    (t0, f0), (t1, f1) = marks[warmup - 1], marks[-1]
    return {"fps": (f1 - f0) / (t1 - t0), "frames_per_epoch": (f1 - f0) / (len(marks) - warmup), "wall_s": wall}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--configs", nargs="+", default=DEFAULT_CONFIGS, help="shipped configs (rlchain/configs)")
    p.add_argument("--nprocs", nargs="+", type=int, default=[2], help="torchrun process counts to compare with 1")
    p.add_argument("--epochs", type=int, default=8, help="measured epochs after the warm-up")
    p.add_argument("--warmup", type=int, default=2, help="epochs not measured (>= 1)")
    p.add_argument("--repeats", type=int, default=1, help="interleaved repeats; the median is reported")
    p.add_argument("--timeout", type=float, default=900, help="seconds per run")
    p.add_argument("--threads-row", action="store_true",
                   help="also 1 process with torch_threads = all cores (slow when other jobs share the cores)")
    p.add_argument("--json", help="write the rows here")
    args = p.parse_args()
    cores = os.cpu_count() or 1
    variants = [(1, None)] + ([(1, cores)] if args.threads_row else []) + [(n, None) for n in args.nprocs]
    names = {(1, None): "1 proc", (1, cores): f"1 proc, {cores} threads"}
    rows = []
    print(f"{cores} cores, load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        for config in args.configs:
            results: dict[tuple, list[dict]] = {v: [] for v in variants}
            for _ in range(args.repeats):
                for nproc, threads in variants:
                    results[(nproc, threads)].append(run_once(config, nproc, threads, args.epochs, args.warmup,
                                                              folder, args.timeout))
            base = statistics.median(r["fps"] for r in results[(1, None)])
            for nproc, threads in variants:
                fps = statistics.median(r["fps"] for r in results[(nproc, threads)])
                rows.append({"config": config, "run": names.get((nproc, threads), f"{nproc} procs (torchrun)"),
                             "processes": nproc, "fps": round(fps), "vs_1_proc": round(fps / base, 2),
                             "frames_per_epoch": results[(nproc, threads)][0]["frames_per_epoch"],
                             "wall_s": round(statistics.median(r["wall_s"] for r in results[(nproc, threads)]), 1)})
    print(f"{'config':<24} {'run':<22} {'frames/epoch':>12} {'fps':>9} {'vs 1 proc':>9} {'wall s':>7}")
    for r in rows:
        print(f"{r['config']:<24} {r['run']:<22} {r['frames_per_epoch']:>12.0f} {r['fps']:>9} "
              f"{r['vs_1_proc']:>8.2f}x {r['wall_s']:>7}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
