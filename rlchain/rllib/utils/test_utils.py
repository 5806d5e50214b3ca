"""``ray.rllib.utils.test_utils``: RLlib's older home of the example-script helpers, and the checks its example
scripts assert with (``check``, ``check_learning_achieved``)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rlchain.rllib.examples.results import flatten
from rlchain.rllib.examples.utils import add_rllib_example_script_args, run_rllib_example_script_experiment
from rlchain.rllib.utils.metrics import ENV_RUNNER_RESULTS, EPISODE_RETURN_MEAN, EVALUATION_RESULTS
from rlchain.rllib.utils.numpy import convert_to_numpy


def _leaves(x: Any, path: str = "") -> list[tuple[str, Any]]:
    if isinstance(x, dict):
        return [leaf for key in sorted(x, key=str) for leaf in _leaves(x[key], f"{path}/{key}")]
    if isinstance(x, (list, tuple)):
        return [leaf for i, v in enumerate(x) for leaf in _leaves(v, f"{path}[{i}]")]
    return [(path, convert_to_numpy(x))]


def check(x: Any, y: Any, decimals: int = 5, atol: float | None = None, rtol: float | None = None,
          false: bool = False) -> None:
    """Assert that ``x`` and ``y`` (nested dicts, lists, arrays, tensors, numbers) are equal, numbers up to
    ``decimals`` digits (or ``atol`` / ``rtol``); with ``false=True`` that they are not."""
    xs, ys = _leaves(x), _leaves(y)
    same = [p for p, _ in xs] == [p for p, _ in ys]
    if same:
        for (_, a), (_, b) in zip(xs, ys):
            try:
                a_arr, b_arr = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
            except (TypeError, ValueError):
                same = a == b
            else:
                if a_arr.shape != b_arr.shape:
                    same = False
                else:
                    exact = atol is None and rtol is None
                    tol = (0.5 * 10.0 ** -decimals, 0.0) if exact else (atol or 0.0, rtol or 0.0)
                    same = bool(np.allclose(a_arr, b_arr, atol=tol[0], rtol=tol[1], equal_nan=True))
            if not same:
                break
    if same == false:
        raise AssertionError(f"check: {'equal' if false else 'not equal'}: {x!r} and {y!r}")


def check_learning_achieved(tune_results: Any, min_value: float, evaluation: bool | None = None,
                            metric: str = f"{ENV_RUNNER_RESULTS}/{EPISODE_RETURN_MEAN}") -> None:
    """A ValueError unless some trial's last result reached ``min_value`` on ``metric`` (on the evaluation's
    when ``evaluation`` is True, or None and the result has one)."""
    rows = [t.history[-1] for t in tune_results if t.history] if hasattr(tune_results, "get_best_result") \
        else [tune_results]
    values = []
    for row in map(flatten, rows):
        key = f"{EVALUATION_RESULTS}/{metric}"
        value = row.get(key) if evaluation or (evaluation is None and key in row) else row.get(metric)
        if isinstance(value, (int, float)) and not math.isnan(value):
            values.append(value)
    if not values or max(values) < min_value:
        raise ValueError(f"`{metric}` of {min_value} not reached!")
    print(f"`{metric}` of {min_value} reached! ok")


__all__ = ["add_rllib_example_script_args", "check", "check_learning_achieved", "run_rllib_example_script_experiment"]
