"""Observation groups resolved against an env's observation space: which flat indices a network reads.

The config block (:class:`rlchain.config.obs_groups.ObsGroupsConfig`) names parts; here they become an
:class:`ObsView`: the indices into the env's flat observation vector, in order, and the space the network is
built for (a Dict of the chosen keys when the view is whole keys, else a flat Box). Named parts are a Dict
observation's keys (:class:`~rlchain.envs.wrappers.dict_obs.FlatDictBox`) and ``obs`` / ``state`` of a
central-value env (:class:`~rlchain.envs.wrappers.central_value.ObsStateBox`, whose Dict parts' keys are
named too); indices and ``"start:stop"`` slices work on any flat observation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from rlchain.config.errors import ConfigError
from rlchain.envs.wrappers.central_value import ObsStateBox
from rlchain.errors import did_you_mean


@dataclass(frozen=True)
class ObsView:
    """One network's view: ``indices`` into the flat observation (in the order the network reads them),
    ``space`` the space it is built for, ``group`` the group's name."""

    group: str
    indices: tuple[int, ...]
    space: gym.Space
    total: int

    @property
    def size(self) -> int:
        """Features the network reads."""
        return len(self.indices)

    @property
    def whole(self) -> bool:
        """True when the view is the whole observation in its own order (nothing to select)."""
        return self.indices == tuple(range(self.total))

    def selector(self) -> slice | tuple[int, ...]:
        """A slice for a contiguous view (cheap, and what ONNX traces best), else the indices."""
        first = self.indices[0]
        if self.indices == tuple(range(first, first + len(self.indices))):
            return slice(first, first + len(self.indices))
        return self.indices

    def take(self, obs: np.ndarray) -> np.ndarray:
        """The view of a batch of flat observations (B, total) -> (B, size), numpy."""
        return np.asarray(obs)[:, list(self.indices)]


def named_parts(space: gym.Space) -> dict[str, tuple[int, int, gym.Space]]:
    """name -> (start, stop, declared space) of every named part of a flat observation space."""
    parts: dict[str, tuple[int, int, gym.Space]] = {}
    if isinstance(space, ObsStateBox):
        obs_space = space.obs_space or gym.spaces.Box(-np.inf, np.inf, (space.obs_size,), np.float32)
        state_space = space.state_space or gym.spaces.Box(-np.inf, np.inf, (space.state_size,), np.float32)
        parts["obs"] = (0, space.obs_size, obs_space)
        parts["state"] = (space.obs_size, space.obs_size + space.state_size, state_space)
        for offset, sub in ((0, space.obs_space), (space.obs_size, space.state_space)):
            parts.update({k: (offset + a, offset + b, s) for k, (a, b, s) in _dict_parts(sub).items()
                          if k not in parts})
        return parts
    return _dict_parts(getattr(space, "dict_space", None) or space)


def _dict_parts(space: gym.Space | None) -> dict[str, tuple[int, int, gym.Space]]:
    if not isinstance(space, gym.spaces.Dict):
        return {}
    out, start = {}, 0
    for key, sub in space.spaces.items():  # gymnasium's flatten order
        size = int(gym.spaces.flatdim(sub))
        out[str(key)] = (start, start + size, sub)
        start += size
    return out


def resolve_view(space: gym.Space, parts: list | None, group: str, path: str, source: str = "") -> ObsView:
    """The view ``parts`` name on the flat observation space ``space``; ``None`` = the whole observation.

    A key the space does not have, an index out of range, a bad slice or a part named twice is a one-line
    :class:`ConfigError` naming ``path`` (e.g. ``params.config.obs_groups.student[1]``)."""
    shape = tuple(getattr(space, "shape", None) or ())
    if len(shape) != 1:
        if parts is None:
            return ObsView(group, (), space, 0)  # images etc.: only the whole observation
        if isinstance(space, gym.spaces.Dict):  # kept per key: the network's own inputs choose the keys
            raise ConfigError(source, path, f"the observations are a Dict kept per key ({', '.join(space.spaces)}): "
                                            f"a multi_input network picks the keys it reads itself "
                                            f"(params.network.inputs.<key>.encoder: none leaves one out)")
        raise ConfigError(source, path, f"observation groups need a flat observation; this env's is {space}")
    total = int(shape[0])
    if parts is None:
        return ObsView(group, tuple(range(total)), getattr(space, "dict_space", None) or space, total)
    named = named_parts(space)
    indices: list[int] = []
    keys: list[str] = []
    for i, part in enumerate(parts):
        where = f"{path}[{i}]"
        if isinstance(part, int):
            index = part + total if part < 0 else part
            if not 0 <= index < total:
                raise ConfigError(source, where, f"index {part} is out of range for an observation of size {total}")
            chosen = [index]
        elif part in named:
            start, stop, _ = named[part]
            chosen = list(range(start, stop))
            keys.append(part)
        elif ":" in part:
            chosen = _slice(part, total, where, source)
        else:
            known = ", ".join(repr(k) for k in named) or "none: a flat observation (use indices or 'start:stop')"
            raise ConfigError(source, where, f"'{part}' is not a part of the observation{did_you_mean(part, named)}"
                                             f"; named parts: {known}")
        twice = sorted(set(chosen) & set(indices))
        if twice:
            raise ConfigError(source, where, f"{part!r} repeats observation index {twice[0]} (named twice)")
        indices.extend(chosen)
    view_space: gym.Space = gym.spaces.Box(-np.inf, np.inf, (len(indices),), np.float32)
    if len(keys) == len(parts):  # whole keys: the network may split them back by key
        subs = {k: named[k][2] for k in keys}
        if isinstance(space, ObsStateBox) and len(keys) == 1 and keys[0] in ("obs", "state"):
            view_space = subs[keys[0]]
        elif all(k not in ("obs", "state") or not isinstance(space, ObsStateBox) for k in keys):
            view_space = gym.spaces.Dict(subs)
            order = [i for k in view_space.spaces for i in range(named[k][0], named[k][1])]
            indices = order  # gymnasium's Dict may reorder the keys: the flat layout follows it
    return ObsView(group, tuple(indices), view_space, total)


def _slice(part: str, total: int, where: str, source: str) -> list[int]:
    try:
        start_s, stop_s = part.split(":")
        start = int(start_s) if start_s.strip() else 0
        stop = int(stop_s) if stop_s.strip() else total
    except ValueError:
        raise ConfigError(source, where, f"'{part}' is not a 'start:stop' slice of integers") from None
    chosen = list(range(total))[start:stop]
    if not chosen:
        raise ConfigError(source, where, f"slice '{part}' selects nothing of an observation of size {total}")
    return chosen


def group_parts(groups: Any, group: str, space: gym.Space) -> list | None:
    """The parts of ``group`` in the ``obs_groups`` block (None = none given): a central-value env's actor
    sees ``obs`` and its critic ``state`` unless the block says otherwise."""
    parts = getattr(groups, group, None) if groups is not None else None
    if parts is None and isinstance(space, ObsStateBox):
        return ["state"] if group == "critic" else ["obs"]
    return parts
