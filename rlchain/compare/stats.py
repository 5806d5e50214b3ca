"""Aggregate statistics over seeds: the interquartile mean (IQM) and bootstrap confidence intervals.

The definitions are rliable's (Agarwal et al., "Deep RL at the Edge of the Statistical Precipice",
NeurIPS 2021), written here in numpy so that ``rlchain compare`` needs neither rliable nor its scipy
and arch dependencies (a few lines each; rlchain's install requirements stay torch, gymnasium,
numpy, pyyaml and tensorboard):

* IQM = ``scipy.stats.trim_mean(scores, 0.25, axis=None)``: sort all scores (runs x tasks, flattened),
  cut ``floor(0.25 * n)`` from each end, average the rest. It is robust to one outlier seed and
  less noisy than the median.
* Stratified bootstrap (``arch.bootstrap.StratifiedBootstrap`` as rliable uses it): each replicate
  resamples the runs with replacement *within each task* (column), so every task keeps its number
  of runs; the statistic of each replicate is computed, and the interval is the percentile interval
  of those (rliable's default ``method='percentile'``, 95%). With one task it is the ordinary
  bootstrap over seeds.

Everything is a pure function of its arguments and a seed: the same call gives the same interval.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Statistic = Callable[[np.ndarray], float]


def _scores(scores: np.ndarray | list) -> np.ndarray:
    """``scores`` as a float array of shape (runs, tasks): a 1-D array is one task."""
    array = np.asarray(scores, dtype=float)
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2 or array.shape[0] == 0 or array.shape[1] == 0:
        raise ValueError(f"scores must be a non-empty (runs,) or (runs, tasks) array, got shape {array.shape}")
    return array


def iqm(scores: np.ndarray | list) -> float:
    """Interquartile mean of all scores: the mean of the middle half (``floor(n / 4)`` cut from each end of
    the sorted, flattened scores; scipy's ``trim_mean(x, 0.25)``). With fewer than 4 scores nothing is cut."""
    flat = np.sort(_scores(scores).ravel())
    cut = int(0.25 * flat.size)
    return float(flat[cut:flat.size - cut].mean())


def mean(scores: np.ndarray | list) -> float:
    """Mean of all scores."""
    return float(_scores(scores).mean())


def median(scores: np.ndarray | list) -> float:
    """Median of all scores."""
    return float(np.median(_scores(scores)))


STATISTICS: dict[str, Statistic] = {"iqm": iqm, "mean": mean, "median": median}


def bootstrap_replicates(scores: np.ndarray | list, statistic: Statistic = iqm, reps: int = 2000,
                         seed: int = 0) -> np.ndarray:
    """``reps`` values of ``statistic`` on stratified resamples of ``scores`` (runs x tasks): in each
    replicate every task's column is resampled, with replacement, from that task's own runs."""
    array = _scores(scores)
    runs, tasks = array.shape
    rng = np.random.default_rng(seed)
    index = rng.integers(0, runs, size=(reps, runs, tasks))  # per replicate, per task: which runs
    resampled = np.take_along_axis(np.broadcast_to(array, (reps, runs, tasks)), index, axis=1)
    return np.array([statistic(sample) for sample in resampled])


def bootstrap_ci(scores: np.ndarray | list, statistic: Statistic = iqm, confidence: float = 0.95,
                 reps: int = 2000, seed: int = 0) -> tuple[float, float]:
    """The percentile bootstrap interval of ``statistic`` (stratified by task): the ``(1 - confidence) / 2``
    and ``(1 + confidence) / 2`` quantiles of :func:`bootstrap_replicates`."""
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    values = bootstrap_replicates(scores, statistic, reps, seed)
    low, high = np.percentile(values, [50.0 * (1.0 - confidence), 50.0 * (1.0 + confidence)])
    return float(low), float(high)


def interval_estimate(scores: np.ndarray | list, statistic: Statistic = iqm, confidence: float = 0.95,
                      reps: int = 2000, seed: int = 0) -> tuple[float, float, float]:
    """``(point, low, high)``: the statistic of ``scores`` and its bootstrap interval."""
    low, high = bootstrap_ci(scores, statistic, confidence, reps, seed)
    return statistic(scores), low, high


__all__ = ["iqm", "mean", "median", "STATISTICS", "bootstrap_replicates", "bootstrap_ci", "interval_estimate"]
