"""What RLlib's ``run_rllib_example_script_experiment`` returns when it runs Tune (no ``--no-tune``): Ray Tune's
``ResultGrid`` read (``get_best_result``, ``get_dataframe``, ``results[0]``, ``experiment_path``), built from the
face's in-process trials. A trial is one variant of the config's ``tune.grid_search`` values; its
:class:`TrialResult` has Tune's ``metrics`` (the last result with ``config``), ``metrics_dataframe`` (every
result, nested keys joined by ``/``), ``checkpoint`` (the last one saved, ``checkpoint.path`` a ``save_to_path``
folder) and ``path``.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

GRID = "grid_search"
SCOPES = ("last", "all", "avg", "last-5-avg", "last-10-avg")


def grid_variants(values: dict[str, Any]) -> list[dict[str, Any]]:
    """The settings of each trial: every combination of the top-level ``{"grid_search": [...]}`` values (Tune's
    order: the first key varies slowest); ``[{}]`` when there is none."""
    grids = {k: v[GRID] for k, v in values.items() if isinstance(v, dict) and set(v) == {GRID}}
    for key, options in grids.items():
        if not isinstance(options, (list, tuple)) or not options:
            raise ValueError(f"tune.grid_search for '{key}': expected a non-empty list, got {options!r}")
    return [dict(zip(grids, combo)) for combo in itertools.product(*grids.values())]


def flatten(result: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """A nested result as Tune's one-level row (``env_runners/episode_return_mean``)."""
    out: dict[str, Any] = {}
    for key, value in result.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "/"))
        else:
            out[name] = value
    return out


@dataclass(frozen=True)
class Checkpoint:
    """Tune's ``Checkpoint`` of a trial: ``path`` is a folder written by ``save_to_path``."""

    path: str

    @classmethod
    def from_directory(cls, path: str) -> Checkpoint:
        return cls(os.fspath(path))

    def to_directory(self, path: str | None = None) -> str:
        return self.path

    @contextlib.contextmanager
    def as_directory(self) -> Iterator[str]:
        yield self.path


@dataclass
class TrialResult:
    """Tune's ``Result`` of one trial (see the module docstring)."""

    config: dict[str, Any]
    path: str
    history: list[dict[str, Any]] = field(default_factory=list)
    checkpoint: Checkpoint | None = None
    error: BaseException | None = None

    @property
    def metrics(self) -> dict[str, Any]:
        return {**(self.history[-1] if self.history else {}), "config": self.config}

    @property
    def metrics_dataframe(self) -> Any:
        import pandas as pd  # Tune's own dependency, as in Ray Tune
        return pd.DataFrame([flatten({**row, "config": self.config}) for row in self.history])

    def value(self, metric: str, mode: str, scope: str) -> float:
        """The trial's ``metric`` as ``get_best_result`` compares it (NaN when never reported)."""
        values = [v for row in self.history
                  if isinstance(v := flatten(row).get(metric), (int, float)) and not math.isnan(v)]
        if not values:
            return math.nan
        if scope == "all":
            return max(values) if mode == "max" else min(values)
        if scope == "last":
            return values[-1]
        last = values if scope == "avg" else values[-int(scope.split("-")[1]):]
        return sum(last) / len(last)


class ResultGrid:
    """Tune's ``ResultGrid`` over the face's trials (see the module docstring)."""

    def __init__(self, results: list[TrialResult], experiment_path: str) -> None:
        self._results = results
        self.experiment_path = experiment_path
        self.errors = [r.error for r in results if r.error is not None]
        self.num_errors = len(self.errors)
        self.num_terminated = len(results) - self.num_errors

    def __len__(self) -> int:
        return len(self._results)

    def __getitem__(self, index: int) -> TrialResult:
        return self._results[index]

    def __iter__(self) -> Any:
        return iter(self._results)

    def get_best_result(self, metric: str | None = None, mode: str | None = None, scope: str = "last",
                        filter_nan_and_inf: bool = True) -> TrialResult:
        """The trial with the best ``metric`` (``mode`` "max" or "min") over ``scope``; one trial is its own best."""
        if metric is None and mode is None and len(self._results) == 1:
            return self._results[0]
        if metric is None or mode not in ("max", "min"):
            raise ValueError(f"get_best_result: pass metric= and mode='max' or 'min' (got {metric!r}, {mode!r})")
        if scope not in SCOPES:
            raise ValueError(f"get_best_result: scope '{scope}' is not one of {', '.join(SCOPES)}")
        scored = [(r.value(metric, mode, scope), i) for i, r in enumerate(self._results)]
        scored = [(v, i) for v, i in scored if not (filter_nan_and_inf and not math.isfinite(v))]
        if not scored:
            raise RuntimeError(f"get_best_result: no trial reported '{metric}'")
        best_value, best = scored[0]
        for value, index in scored[1:]:  # the first of equal trials, as Tune keeps it
            if (value > best_value) if mode == "max" else (value < best_value):
                best_value, best = value, index
        return self._results[best]

    def get_dataframe(self, filter_metric: str | None = None, filter_mode: str | None = None) -> Any:
        """One row per trial: its last result, or its row with the best ``filter_metric``."""
        import pandas as pd  # Tune's own dependency, as in Ray Tune
        rows = []
        for r in self._results:
            frame = r.metrics_dataframe
            if frame.empty:
                continue
            if filter_metric is not None and filter_metric in frame:
                column = frame[filter_metric]
                rows.append(frame.loc[column.idxmax() if filter_mode == "max" else column.idxmin()])
            else:
                rows.append(frame.iloc[-1])
        return pd.DataFrame(rows).reset_index(drop=True)


def checkpoint_folder(trial_path: str, index: int) -> str:
    """Tune's name for a trial's ``index``-th checkpoint."""
    return os.path.join(trial_path, f"checkpoint_{index:06d}")
