"""The Markdown table of ``rlchain compare``: each group's IQM (or mean / median) over its runs, with a
bootstrap confidence interval, at chosen frames and seconds, for each compared tag."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from rlchain.compare.runs import Run
from rlchain.compare.stats import STATISTICS, interval_estimate


@dataclass(frozen=True)
class Settings:
    """How the table's cells are computed: the statistic over runs, and its bootstrap interval."""

    statistic: str = "iqm"
    confidence: float = 0.95
    reps: int = 2000
    seed: int = 0


def number(value: float) -> str:
    """A value as the table shows it: whole numbers from 100 up, else three significant digits."""
    if not math.isfinite(value):
        return str(value)
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.3g}"


def round_down(value: float) -> float:
    """``value`` rounded down to two significant digits (a grid point every run reached): 1_234_567 -> 1_200_000,
    0.456 -> 0.45."""
    if value <= 0:
        return 0.0
    step = 10.0 ** (math.floor(math.log10(value)) - 1)
    return float(f"{math.floor(value / step + 1e-9) * step:.12g}")


def default_points(runs: Sequence[Run], tag: str, axis: str, count: int = 4) -> list[float]:
    """``count`` even points up to the last x every run reached on ``axis`` (two significant digits)."""
    reach = min(run.curves[tag].end(axis) for run in runs if run.curves[tag].values.size)
    points = sorted({round_down(reach * k / count) for k in range(1, count + 1)} - {0.0})
    return points or [reach]


def values_at(runs: Sequence[Run], tag: str, x: float, axis: str) -> list[float]:
    """The value of ``tag`` at ``x`` of every run that reached ``x`` (the last value reported at or before it)."""
    values = [run.curves[tag].value_at(x, axis) for run in runs]
    return [v for v in values if v is not None]


def x_label(x: float, axis: str) -> str:
    """``1.2M frames``, ``350k frames``, ``90 s``."""
    if axis == "seconds":
        return f"{x:g} s"
    for suffix, scale in (("M", 1e6), ("k", 1e3)):
        if x >= scale:
            return f"{x / scale:g}{suffix} frames"
    return f"{x:g} frames"


def cell(values: Sequence[float], total: int, settings: Settings) -> str:
    """``IQM [low, high] (n/N)`` over the runs that have a value; ``-`` when none has."""
    if not values:
        return f"- (0/{total})"
    point, low, high = interval_estimate(values, STATISTICS[settings.statistic], settings.confidence,
                                         settings.reps, settings.seed)
    return f"{number(point)} [{number(low)}, {number(high)}] ({len(values)}/{total})"


def table(groups: dict[str, list[Run]], tag: str, axis: str, points: Sequence[float], settings: Settings) -> list[str]:
    """Markdown rows: one per point, one column per group."""
    labels = list(groups)
    lines = ["| at | " + " | ".join(labels) + " |", "|---|" + "---|" * len(labels)]
    for x in points:
        cells = [cell(values_at(groups[label], tag, x, axis), len(groups[label]), settings) for label in labels]
        lines.append(f"| {x_label(x, axis)} | " + " | ".join(cells) + " |")
    return lines


def report(groups: dict[str, list[Run]], tags: Sequence[str], at_frames: Sequence[float] | None,
           at_seconds: Sequence[float] | None, settings: Settings, images: dict[str, str] | None = None) -> str:
    """The whole Markdown report: the groups and their runs, then per tag a table against frames and one
    against seconds (``at_*`` None: four even points each), and its plot when ``images`` names one."""
    every = [run for runs in groups.values() for run in runs]
    pct = f"{settings.confidence * 100:g}%"
    lines = [f"Each cell: {settings.statistic.upper() if settings.statistic == 'iqm' else settings.statistic} "
             f"over the group's runs [{pct} stratified bootstrap confidence interval, {settings.reps} resamples, "
             f"seed {settings.seed}] (runs that reached that point / runs). A run's value at a point is the last one "
             f"it logged at or before it.", ""]
    for label, runs in groups.items():
        lines.append(f"- **{label}**: {len(runs)} run{'s' if len(runs) != 1 else ''} "
                     f"({', '.join(f'`{run.name}`' for run in runs)})")
    for tag in tags:
        lines += ["", f"### {tag}", ""]
        for axis, chosen in (("frames", at_frames), ("seconds", at_seconds)):
            points = list(chosen) if chosen else default_points(every, tag, axis)
            lines += table(groups, tag, axis, points, settings) + [""]
        if images and tag in images:
            lines.append(f"![{tag}]({images[tag]})")
    return "\n".join(lines).rstrip() + "\n"


__all__ = ["Settings", "number", "round_down", "default_points", "values_at", "x_label", "cell", "table", "report"]
