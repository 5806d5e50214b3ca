"""Per-epoch means of numeric step-info keys (``params.config.log_info_keys``), for TensorBoard.

Robot-learning envs report their reward terms and task measures in the step infos (MuJoCo
Playground on envpool: ``reward_box_target``, ``reward_gripper_box`` ...; MetaWorld:
``near_object``, ``obj_to_target``). Each named key is averaged over every env row of every step of
an epoch and logged as ``env_info/<key>``. Non-numeric values and NaNs are skipped. A key that is not in the
infos is looked up in ``infos['episode']``, where Isaac Lab-style envs (mjlab) put their per-episode log
(``Episode_Reward/track_linear_velocity``, ``Curriculum/...``) at the steps where envs reset.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rlchain.errors import did_you_mean
from rlchain.log import get_logger

log = get_logger(__name__)

PREFIX = "env_info/"
EPISODE = "episode"


class InfoMeans:
    """Sums the named info keys over steps; :meth:`pop` gives the epoch's means and starts afresh.
    A key the env never reported in the first epoch gets one warning naming the keys it did report."""

    def __init__(self, keys: list[str] | tuple[str, ...] = ()) -> None:
        self.keys = tuple(keys)
        self._sums = dict.fromkeys(self.keys, 0.0)
        self._counts = dict.fromkeys(self.keys, 0)
        self._reported: set[str] = set()
        self._checked = False

    def add(self, infos: Any) -> None:
        """Fold one step's ``infos`` (a dict of per-env arrays or tensors) in."""
        if not self.keys or not isinstance(infos, dict):
            return
        episode = infos.get(EPISODE)
        episode = episode if isinstance(episode, dict) else {}
        if not self._checked:
            self._reported.update(str(k) for k in (*infos, *episode))
        for key in self.keys:
            value = infos.get(key, episode.get(key))
            if value is None:
                continue
            if hasattr(value, "detach"):
                value = value.detach().cpu().numpy()
            try:
                values = np.asarray(value, dtype=np.float64).reshape(-1)
            except (TypeError, ValueError):
                continue
            values = values[np.isfinite(values)]
            self._sums[key] += float(values.sum())
            self._counts[key] += int(values.size)

    def totals(self) -> tuple[dict[str, float], dict[str, int], set[str]]:
        """(sums, counts, keys the env reported) since the last :meth:`totals`, then starts afresh:
        what an APPO runner hands the learner with a fragment."""
        out = (dict(self._sums), dict(self._counts), set(self._reported))
        self._sums = dict.fromkeys(self.keys, 0.0)
        self._counts = dict.fromkeys(self.keys, 0)
        self._reported.clear()
        return out

    def add_totals(self, sums: dict[str, float], counts: dict[str, int], reported: set[str]) -> None:
        """Fold in another tracker's :meth:`totals` (a runner's fragment)."""
        if not self._checked:
            self._reported.update(reported)
        for key in self.keys:
            self._sums[key] += sums.get(key, 0.0)
            self._counts[key] += counts.get(key, 0)

    def pop(self) -> dict[str, float]:
        """``{'env_info/<key>': mean}`` of the keys seen since the last pop."""
        out = {f"{PREFIX}{key}": self._sums[key] / self._counts[key] for key in self.keys if self._counts[key]}
        if self.keys and not self._checked:
            self._checked = True
            for key in self.keys:
                if not self._counts[key]:
                    hint = did_you_mean(key, self._reported)
                    log.warning(f"params.config.log_info_keys: '{key}' was not a numeric key of the env's step "
                                f"infos in the first epoch{hint} (keys seen: {', '.join(sorted(self._reported))})")
        self._sums = dict.fromkeys(self.keys, 0.0)
        self._counts = dict.fromkeys(self.keys, 0)
        return out
