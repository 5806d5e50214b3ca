"""Task success from an env's step infos: ``info['success']`` (MetaWorld, MuJoCo Playground),
``info['is_success']`` (gymnasium-robotics Fetch), or any key a config names.

Where the value of a finished episode's last step lives depends on the backend:

- envpool: ``infos[key]`` at the step that ended the episode (envpool's own reset comes on the
  next step, see ``envpool_env.py``), an (N,) array;
- gymnasium vector envs with same-step auto-reset: ``infos['final_info'][key]`` for the rows that
  ended (``infos[key]`` there belongs to the reset), with ``_key`` masks saying which rows hold it.

:func:`step_success` reads both into one (N,) float array, NaN where a row has no value this step.
An episode counts as a success when the value was > 0.5 at any of its steps (``success_mode: any``,
MetaWorld's rule) or at its last step (``last``, gymnasium-robotics' rule).
"""

from __future__ import annotations

from typing import Any

import numpy as np

AUTO_KEYS = ("success", "is_success")
"""The info keys ``success_key: auto`` looks for, in this order."""

OFF = ("none", "off", "")
MODES = ("any", "last")


def resolve_key(key: str, infos: Any) -> str | None:
    """The info key that holds success for ``success_key`` = ``key`` given one step's ``infos``.

    ``auto``: the first of :data:`AUTO_KEYS` present in ``infos`` or its ``final_info``; a name: that
    name; ``none`` / ``off``: None (no success rate).
    """
    if key.lower() in OFF:
        return None
    if key != "auto":
        return key
    if not isinstance(infos, dict):
        return None
    final = infos.get("final_info")
    for name in AUTO_KEYS:
        if name in infos or (isinstance(final, dict) and name in final):
            return name
    return None


def _column(source: dict, key: str, n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(values (n,) float, present (n,) bool) of ``source[key]``, None when absent or not one per row."""
    if key not in source:
        return None
    value = source[key]
    if hasattr(value, "detach"):  # a torch tensor (tensor envs)
        value = value.detach().cpu().numpy()
    try:
        value = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        return None
    if value.shape[0] != n:
        return None
    present = np.asarray(source.get(f"_{key}", np.ones(n, bool)), dtype=bool).reshape(-1)
    return value, present if present.shape[0] == n else np.ones(n, bool)


def step_success(infos: Any, key: str, dones: np.ndarray) -> np.ndarray | None:
    """(N,) float: ``key``'s value at this step per row (the ended episode's last step for ``dones``
    rows), NaN where a row has none; None when no row has one (the env reports no success)."""
    if not isinstance(infos, dict):
        return None
    dones = np.asarray(dones, dtype=bool).reshape(-1)
    n = dones.shape[0]
    out = np.full(n, np.nan)
    current = _column(infos, key, n)
    if current is not None:
        out[current[1]] = current[0][current[1]]
    final = infos.get("final_info")
    if isinstance(final, dict):  # gymnasium: a finished row's infos[key] is its reset's, not the episode's
        out[dones] = np.nan
        last = _column(final, key, n)
        if last is not None:
            rows = dones & last[1]
            out[rows] = last[0][rows]
    return None if np.isnan(out).all() else out


class SuccessReader:
    """Reads per-step success from a run's step infos for ``success_key`` (resolving ``auto`` once the
    env has shown a key); :meth:`read` returns None for envs that report none."""

    def __init__(self, success_key: str = "auto") -> None:
        self.setting = success_key
        self.key: str | None = None
        self.off = success_key.lower() in OFF

    def read(self, infos: Any, dones: Any) -> np.ndarray | None:
        """(N,) float success values of one step (NaN: none), or None; ``dones`` (N,) bool, array or tensor."""
        if self.off or not isinstance(infos, dict):
            return None
        if self.key is None:
            self.key = resolve_key(self.setting, infos)
            if self.key is None:
                return None
        if hasattr(dones, "detach"):
            dones = dones.detach().cpu().numpy()
        return step_success(infos, self.key, dones)
