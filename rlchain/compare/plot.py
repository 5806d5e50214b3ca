"""Seed-aggregated curves: a tag against frames and against seconds, one line and a band per group.

matplotlib (a core dependency) is imported only here and only when a plot is drawn; :func:`bands` is numpy and
needs no display.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rlchain.compare.runs import CompareError, Run
from rlchain.compare.stats import bootstrap_ci

BANDS = ("minmax", "ci", "std")


def bands(runs: Sequence[Run], tag: str, axis: str, band: str = "minmax", points: int = 200,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(x, mean, low, high)`` over ``runs`` at ``points`` even x values up to the last one every run
    reached, where every run has a value (each run's last value at or before x). ``band``: ``minmax`` (the
    seeds' range), ``ci`` (95% bootstrap interval of the mean, 500 resamples) or ``std`` (mean +- one sample
    standard deviation)."""
    if band not in BANDS:
        raise CompareError(f"--band: expected one of {', '.join(BANDS)}, got '{band}'")
    curves = [run.curves[tag] for run in runs]
    end = min(c.end(axis) for c in curves)
    out: tuple[list[float], list[float], list[float], list[float]] = ([], [], [], [])
    for x in np.linspace(0.0, end, points + 1):
        values = [c.value_at(float(x), axis) for c in curves]
        if any(v is None for v in values):
            continue
        array = np.asarray(values, dtype=float)
        center = float(array.mean())
        if band == "minmax":
            low, high = float(array.min()), float(array.max())
        elif band == "std":
            spread = float(array.std(ddof=1)) if array.size > 1 else 0.0
            low, high = center - spread, center + spread
        else:
            low, high = bootstrap_ci(array, np.mean, reps=500, seed=seed) if array.size > 1 else (center, center)
        for series, v in zip(out, (float(x), center, low, high)):
            series.append(v)
    return tuple(np.asarray(s) for s in out)  # type: ignore[return-value]


def pyplot():
    """matplotlib.pyplot on the Agg backend; a missing matplotlib is a one-line CompareError naming the extra."""
    try:
        import matplotlib  # optional: matplotlib (imported only to draw)
    except ImportError:
        raise CompareError("the plots need matplotlib (an rlchain dependency): pip install matplotlib "
                           "(or pass --no-plot)") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # optional: matplotlib (imported only to draw)

    return plt


BAND_NAMES = {"minmax": "min-max over seeds", "ci": "95% bootstrap CI of the mean", "std": "+- 1 std over seeds"}
AXIS_NAMES = {"frames": "frames", "seconds": "seconds from the run's start"}


def plot_tag(groups: dict[str, list[Run]], tag: str, path: str, title: str = "", band: str = "minmax",
             colors: dict[str, str] | None = None, ylabel: str | None = None, legend_loc: str = "best",
             xlabels: dict[str, str] | None = None) -> str:
    """A PNG at ``path``: ``tag`` against frames (left) and against seconds (right), per group the mean over
    its runs and a ``band``; returns ``path``."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for label, runs in groups.items():
        color = (colors or {}).get(label)
        for ax, axis in zip(axes, ("frames", "seconds")):
            x, mean, low, high = bands(runs, tag, axis, band)
            line, = ax.plot(x, mean, color=color, label=f"{label} ({len(runs)} seed{'s' if len(runs) != 1 else ''})")
            ax.fill_between(x, low, high, color=line.get_color(), alpha=0.2)
    for ax, axis in zip(axes, ("frames", "seconds")):
        ax.set_xlabel((xlabels or AXIS_NAMES)[axis])
        ax.set_ylabel(ylabel or tag)
        ax.grid(alpha=0.3)
        ax.legend(loc=legend_loc, fontsize=7)
    fig.suptitle(title or f"{tag}: mean and {BAND_NAMES[band]}")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def slug(tag: str) -> str:
    """A file name for a tag: ``rewards/step`` -> ``rewards_step``."""
    return "".join(ch if ch.isalnum() or ch in "-." else "_" for ch in tag)


__all__ = ["BANDS", "bands", "pyplot", "plot_tag", "slug"]
