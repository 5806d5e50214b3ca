"""``rlchain benchmark``: EmbodiChain's benchmark protocol over configs (tasks x algorithms) x seeds.

    rlchain benchmark cfg_a.json cfg_b.yaml --seeds 0 1 2 --threshold 0.8 --task-threshold push_cube=0.6 \\
        --out bench/ [key.path=value ...]

Each config is one (task, algorithm) pair: any rlchain or EmbodiChain config with in-training evaluation
(``config.evaluation`` / ``trainer.enable_eval``). Every seed trains in its own process (``rlchain train``),
so each run's peak memory is its own (the GPU's peak allocation when it ran on CUDA, else its peak resident
memory: rlchain.compare.peak_memory); the run's TensorBoard curves then give its metrics
(rlchain.compare.protocol): final and stable success (last 3 evaluations), steps and seconds to the success
threshold (first of 3 consecutive evaluations at or above it), final evaluation reward, training fps (env
steps per second of the run) and env fps (``performance/step_fps``), peak memory. Writes ``report.md`` and
``report.json`` (runs, per task and algorithm with the IQM and its 95% interval, the leaderboard) to ``--out``.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import subprocess
import sys
import time
from typing import Any

from rlchain.builtins import register_builtins
from rlchain.compare.peak_memory import reported
from rlchain.compare.protocol import aggregate, first_sustained, leaderboard, stable
from rlchain.compare.runs import read_curves
from rlchain.config.load import load_config

EVAL_SUCCESS, EVAL_REWARD = "evaluation/success_rate", "evaluation/rewards"
TRAIN_SUCCESS, TRAIN_REWARD = "episodes/success_rate", "rewards/step"
ALGO_NAMES = {"a2c_continuous": "ppo", "a2c_discrete": "ppo"}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="rlchain benchmark", description=__doc__.splitlines()[0])
    p.add_argument("configs", nargs="+", help="configs (rlchain or EmbodiChain layout), one per task x algorithm; "
                   "then key.path=value overrides for every run")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--threshold", type=float, default=0.8, help="success threshold (EmbodiChain: cart_pole 0.8)")
    p.add_argument("--task-threshold", action="append", default=[], metavar="TASK=VALUE",
                   help="per-task threshold (EmbodiChain: push_cube=0.6)")
    p.add_argument("--window", type=int, default=3, help="evaluations the stable success averages")
    p.add_argument("--sustain", type=int, default=3, help="consecutive evaluations at the threshold")
    p.add_argument("--out", default="benchmark", help="folder for runs/, report.md and report.json")
    return p


def describe(config: str, overrides: list[str]) -> tuple[str, str]:
    """(task, algorithm) of a config: its env name and algorithm (PPO's algos read as ppo)."""
    register_builtins()
    params = load_config(config, overrides)
    return params.config.env_name, ALGO_NAMES.get(params.algo.name, params.algo.name)


def train_run(config: str, seed: int, train_dir: str, overrides: list[str]) -> tuple[int, float, dict[str, Any]]:
    """Train one seed in its own process: (exit status, wall seconds, its memory record: see
    :func:`memory_record`)."""
    os.makedirs(train_dir, exist_ok=True)
    peaks_file = os.path.join(train_dir, "peak_memory.json")
    cmd = [sys.executable, "-m", "rlchain.compare.peak_memory", peaks_file, "--", "train", config, "--seed",
           str(seed), f"params.config.train_dir={train_dir}", "params.config.print_stats=false", *overrides]
    start = time.time()
    proc = subprocess.Popen(cmd)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    seconds = time.time() - start
    peaks: dict[str, Any] = {"cpu_peak_rss_mb": usage.ru_maxrss / 1024.0, "gpu_peak_memory_mb": None}  # Linux: KB
    if os.path.isfile(peaks_file):  # absent when the process died before writing it
        with open(peaks_file, encoding="utf-8") as fh:
            peaks.update(json.load(fh))
    return proc.returncode, seconds, memory_record(peaks)


def memory_record(peaks: dict[str, Any]) -> dict[str, Any]:
    """A run's memory fields: ``cpu_peak_rss_mb``, ``gpu_peak_memory_mb`` (None on a CPU run) and the one the
    report shows, ``peak_memory_mb`` with ``peak_memory_kind`` (``gpu`` when the run used CUDA, else
    ``cpu_rss``)."""
    value, kind = reported(peaks)
    return {"cpu_peak_rss_mb": peaks.get("cpu_peak_rss_mb"), "gpu_peak_memory_mb": peaks.get("gpu_peak_memory_mb"),
            "peak_memory_mb": value, "peak_memory_kind": kind}


def run_metrics(run_dir: str, threshold: float, window: int, sustain: int) -> dict[str, Any]:
    """The protocol's metrics of one finished run folder (see the module docstring)."""
    curves = read_curves(run_dir)
    success = curves.get(EVAL_SUCCESS) or curves.get(TRAIN_SUCCESS)
    reward = curves.get(EVAL_REWARD) or curves.get(TRAIN_REWARD)
    out: dict[str, Any] = {"success_source": EVAL_SUCCESS if EVAL_SUCCESS in curves else
                           TRAIN_SUCCESS if success is not None else None}
    if success is not None and success.values.size:
        values = success.values.tolist()
        out["final_success_rate"] = values[-1]
        out["final_success_rate_stable"] = stable(values, window)
        out["steps_to_success_threshold"] = first_sustained(success.frames.tolist(), values, threshold, sustain)
        out["seconds_to_success_threshold"] = first_sustained(success.seconds.tolist(), values, threshold, sustain)
    if reward is not None and reward.values.size:
        out["final_reward"] = float(reward.values[-1])
    longest = max(curves.values(), key=lambda c: c.end("frames"))
    frames, seconds = longest.end("frames"), longest.end("seconds")
    out["frames"] = frames
    out["training_fps"] = frames / seconds if seconds > 0 else float("nan")
    env_fps = curves.get("performance/step_fps")
    if env_fps is not None and env_fps.values.size:
        out["env_fps"] = float(env_fps.values.mean())
    return out


def _fmt(value: Any, digits: int = 2) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, float) and abs(value) >= 1000:
        return f"{value:,.0f}"
    return f"{value:.{digits}f}" if isinstance(value, float) else str(value)


def _peak_cell(row: dict[str, Any]) -> str:
    """The mean peak with what it measures: GPU (allocated on CUDA) or RSS (CPU resident set)."""
    kind = {"gpu": "GPU", "cpu_rss": "RSS"}.get(row.get("peak_memory_kind", ""), row.get("peak_memory_kind", ""))
    value = _fmt(row.get("peak_memory_mb_mean"), 0)
    return f"{value} {kind}".strip() if value != "-" else "-"


def markdown(rows: list[dict[str, Any]], board: list[dict[str, Any]], thresholds: dict[str, float]) -> str:
    """The report: per task and algorithm, then the leaderboard."""
    lines = ["# Benchmark report", "", "Stable success: mean of the last 3 evaluations. Steps / seconds to threshold: "
             "first of 3 consecutive evaluations at or above the task's threshold (mean over the runs that "
             "reached it). IQM: interquartile mean over seeds with its 95% bootstrap interval. Peak memory: the "
             "GPU's peak allocation (GPU) on CUDA runs, else the process's peak resident set (RSS).", "",
             "| task | algorithm | runs | threshold | stable success | IQM [95% CI] | reached | steps to threshold "
             "| seconds to threshold | final reward | training fps | env fps | peak memory MB |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        iqm = (f"{_fmt(r.get('stable_success_iqm'))} [{_fmt(r.get('stable_success_iqm_low'))}, "
               f"{_fmt(r.get('stable_success_iqm_high'))}]") if "stable_success_iqm" in r else "-"
        stable_cell = (f"{_fmt(r.get('final_success_rate_stable_mean'))} ± "
                       f"{_fmt(r.get('final_success_rate_stable_std'))}") \
            if "final_success_rate_stable_mean" in r else "-"
        lines.append(f"| {r['task']} | {r['algorithm']} | {r['num_runs']} | {thresholds.get(r['task'])} | "
                     f"{stable_cell} | {iqm} | {r['runs_reaching_threshold']}/{r['num_runs']} | "
                     f"{_fmt(r.get('steps_to_success_threshold_mean'), 0)} | "
                     f"{_fmt(r.get('seconds_to_success_threshold_mean'), 0)} | {_fmt(r.get('final_reward_mean'))} | "
                     f"{_fmt(r.get('training_fps_mean'), 0)} | {_fmt(r.get('env_fps_mean'), 0)} | "
                     f"{_peak_cell(r)} |")
    lines += ["", "## Leaderboard (score: stable success averaged over tasks)", "",
              "| rank | algorithm | score | steps to threshold | tasks |", "|---|---|---|---|---|"]
    for b in board:
        tasks = ", ".join(f"{t} {_fmt(v)}" for t, v in sorted(b["tasks"].items()))
        lines.append(f"| {b['rank']} | {b['algorithm']} | {_fmt(b['score'])} | "
                     f"{_fmt(b['steps_to_success_threshold'], 0)} | {tasks} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_intermixed_args(argv)
    configs = [c for c in args.configs if "=" not in c]
    overrides = [c for c in args.configs if "=" in c]
    thresholds_by_task = {}
    for item in args.task_threshold:
        task, _, value = item.partition("=")
        try:
            thresholds_by_task[task] = float(value)
        except ValueError:
            parser.error(f"--task-threshold {item!r}: expected TASK=VALUE")
    runs, thresholds = [], {}
    for config in configs:
        task, algorithm = describe(config, overrides)
        threshold = thresholds_by_task.get(task, args.threshold)
        thresholds[task] = threshold
        for seed in args.seeds:
            train_dir = os.path.join(args.out, "runs", f"{task}_{algorithm}_seed{seed}")
            status, seconds, memory = train_run(config, seed, train_dir, overrides)
            run: dict[str, Any] = {"task": task, "algorithm": algorithm, "seed": seed, "config": config,
                                   "status": status, "seconds": seconds, **memory}
            folders = sorted(glob.glob(os.path.join(train_dir, "*", "")))
            if status == 0 and folders:
                run["run_dir"] = folders[-1]
                run.update(run_metrics(folders[-1], threshold, args.window, args.sustain))
            runs.append(run)
            print(f"benchmark: {task} {algorithm} seed {seed}: status {status}, stable success "
                  f"{_fmt(run.get('final_success_rate_stable'))}, {seconds:.0f} s", flush=True)
    rows = aggregate(runs)
    board = leaderboard(rows)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "report.json"), "w", encoding="utf-8") as fh:
        json.dump({"thresholds": thresholds, "runs": runs, "aggregate": rows, "leaderboard": board}, fh, indent=2)
    text = markdown(rows, board, thresholds)
    with open(os.path.join(args.out, "report.md"), "w", encoding="utf-8") as fh:
        fh.write(text)
    print(text)
    return 0 if all(r["status"] == 0 for r in runs) else 1


if __name__ == "__main__":
    sys.exit(main())
