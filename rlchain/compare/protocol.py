"""EmbodiChain's benchmark protocol as pure functions over evaluation histories, with rlchain's statistics.

Per run, from its in-training evaluations (x = env steps): the final success rate (the last evaluation),
the stable one (mean of the last ``window`` = 3 evaluations), and the steps to the success threshold: the
first evaluation of ``sustain`` = 3 consecutive ones at or above it (None when never). Per task and
algorithm: the mean and population std over seeds (EmbodiChain's aggregate) and the IQM of the stable
success with its 95% bootstrap interval (rlchain.compare.stats). The leaderboard ranks algorithms by
their stable success averaged over tasks (EmbodiChain's score)."""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from statistics import mean, pstdev
from typing import Any

from rlchain.compare.stats import interval_estimate

SCALARS = ("final_reward", "final_success_rate", "final_success_rate_stable", "training_fps", "env_fps",
           "peak_memory_mb", "cpu_peak_rss_mb", "gpu_peak_memory_mb", "seconds")
STEPS = ("steps_to_success_threshold", "seconds_to_success_threshold")


def stable(values: Sequence[float], window: int = 3) -> float | None:
    """Mean of the last ``window`` finite values; None when there is none."""
    finite = [float(v) for v in values if v is not None and math.isfinite(v)]
    return mean(finite[-max(1, window):]) if finite else None


def first_sustained(xs: Sequence[float], values: Sequence[float], threshold: float, sustain: int = 3) -> float | None:
    """The x of the first of ``sustain`` consecutive values at or above ``threshold``; None when never."""
    hits, start = 0, None
    for x, v in zip(xs, values):
        if v is not None and math.isfinite(v) and v >= threshold:
            hits += 1
            start = x if start is None else start
            if hits >= sustain:
                return start
        else:
            hits, start = 0, None
    return None


def aggregate(runs: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per (task, algorithm): num_runs, <key>_mean / <key>_std of each metric present, and the IQM of the
    stable success with its 95% bootstrap interval (stable_success_iqm, _low, _high)."""
    grouped: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for run in runs:
        grouped[(run["task"], run["algorithm"])].append(run)
    out = []
    for (task, algorithm), items in sorted(grouped.items()):
        row: dict[str, Any] = {"task": task, "algorithm": algorithm, "num_runs": len(items)}
        for key in (*SCALARS, *STEPS):
            values = [float(r[key]) for r in items if isinstance(r.get(key), (int, float)) and math.isfinite(r[key])]
            if values:
                row[f"{key}_mean"] = mean(values)
                row[f"{key}_std"] = pstdev(values) if len(values) > 1 else 0.0
        kinds = {r["peak_memory_kind"] for r in items if r.get("peak_memory_kind")}
        if kinds:  # what peak_memory_mb measures: gpu, cpu_rss, or mixed over the runs
            row["peak_memory_kind"] = kinds.pop() if len(kinds) == 1 else "mixed"
        row["runs_reaching_threshold"] = sum(r.get("steps_to_success_threshold") is not None for r in items)
        scores = [float(r["final_success_rate_stable"]) for r in items
                  if isinstance(r.get("final_success_rate_stable"), (int, float))]
        if scores:
            point, low, high = interval_estimate(scores)
            row.update(stable_success_iqm=point, stable_success_iqm_low=low, stable_success_iqm_high=high)
        out.append(row)
    return out


def leaderboard(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Algorithms ranked by their stable success averaged over tasks (ties: by name); rank from 1."""
    by_algo: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for row in rows:
        by_algo[row["algorithm"]].append(row)
    board = []
    for algorithm, items in by_algo.items():
        scores = [r["final_success_rate_stable_mean"] for r in items if "final_success_rate_stable_mean" in r]
        steps = [r["steps_to_success_threshold_mean"] for r in items if "steps_to_success_threshold_mean" in r]
        board.append({"algorithm": algorithm, "score": mean(scores) if scores else float("nan"),
                      "steps_to_success_threshold": mean(steps) if steps else float("nan"),
                      "tasks": {r["task"]: r.get("final_success_rate_stable_mean") for r in items},
                      "tasks_covered": len(items)})
    board.sort(key=lambda b: (-b["score"] if math.isfinite(b["score"]) else math.inf, b["algorithm"]))
    for rank, entry in enumerate(board, start=1):
        entry["rank"] = rank
    return board
