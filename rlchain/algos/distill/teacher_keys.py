"""Which keys of Dict observations kept per key a distillation's teacher reads, and its input made of them.

A camera student (``network.name: multi_input``) makes the env keep its Dict observations per key
(image, proprioception, privileged state such as the goal's position). The teacher, trained on privileged
state, reads some of those keys:

- ``obs_groups.teacher`` names them (keys only: the observations are not one flat vector here);
- left out, the keys of the group the teacher was trained on when its own config named keys;
- else every key (a ``multi_input`` teacher then leaves out what its own ``inputs`` say ``encoder: none``).

A ``multi_input`` teacher gets those keys per key; a flat teacher (an MLP trained on a state vector) gets
their values concatenated in the order named, which must be the layout it was trained on.
"""

from __future__ import annotations

import re
from collections import OrderedDict

import gymnasium as gym
import numpy as np
import torch

from rlchain.config.errors import ConfigError
from rlchain.envs.obs_dict import ObsDict
from rlchain.errors import did_you_mean

PATH = "params.config.obs_groups.teacher"


def teacher_keys(space: gym.spaces.Dict, chosen: list | None, trained: list | None, source: str,
                 teacher: str) -> tuple[str, ...]:
    """The keys of ``space`` the teacher (checkpoint ``teacher``) reads: ``chosen`` (``obs_groups.teacher``, in
    its order), else ``trained`` (the parts of the group it was trained on; the Dict's order, as its flat view
    was laid out), else every key. A part that is not a key is a one-line :class:`ConfigError`."""
    keys = list(space.spaces)
    if chosen is not None:
        out: list[str] = []
        for i, part in enumerate(chosen):
            where = f"{PATH}[{i}]"
            if not isinstance(part, str):
                raise ConfigError(source, where, f"{part!r}: the observations are a Dict kept per key "
                                                 f"({', '.join(keys)}); the teacher's view names keys, not indices")
            if part not in space.spaces:
                raise ConfigError(source, where, f"'{part}' is not a key of the observations"
                                                 f"{did_you_mean(part, keys)}; keys: {', '.join(keys)}")
            if part in out:
                raise ConfigError(source, where, f"'{part}' is named twice")
            out.append(part)
        return tuple(out)
    if trained is not None:
        if all(isinstance(p, str) and p in space.spaces for p in trained):
            return tuple(gym.spaces.Dict({k: space.spaces[k] for k in trained}).spaces)  # gymnasium's order
        raise ConfigError(source, PATH, f"the teacher in {teacher} was trained on the parts {trained} of its "
                                        f"observation, not keys of this run's Dict observations ({', '.join(keys)}): "
                                        f"name the keys it reads")
    return tuple(keys)


ENCODER = re.compile(r"\.encoders\.([^.]+)\.")


def check_encoded(weights: dict, keys: tuple[str, ...], space: gym.spaces.Dict, chosen: bool, source: str,
                  teacher: str) -> None:
    """A multi_input teacher's ``weights`` name the keys it encodes (``...encoders.<key>...``): each must be among
    the ``keys`` it is given, else a one-line :class:`ConfigError` (``obs_groups.teacher`` when ``chosen``)."""
    encoded = sorted({m.group(1) for name in weights for m in [ENCODER.search(name)] if m})
    lacking = [k for k in encoded if k not in keys]
    if not lacking:
        return
    if chosen:
        raise ConfigError(source, PATH, f"leaves out {', '.join(lacking)}, which the teacher in {teacher} reads "
                                        f"(it encodes {', '.join(encoded)})")
    raise ConfigError(source, "params.config.teacher_checkpoint",
                      f"the teacher in {teacher} reads {', '.join(lacking)} (it encodes {', '.join(encoded)}), "
                      f"which this run's observations ({', '.join(space.spaces)}) lack")


class TeacherInput:
    """The teacher's input made of per-key observations (an ObsDict (N, ...) per key): the ``keys`` per key
    (``per_key``: a multi_input teacher) or their values flattened per row and concatenated in ``keys``' order."""

    def __init__(self, keys: tuple[str, ...], per_key: bool) -> None:
        self.keys, self.per_key = keys, per_key

    def space(self, space: gym.spaces.Dict) -> gym.Space:
        """The space the teacher is built for: the Dict of its keys (in ``space``'s order) or a flat Box."""
        if self.per_key:
            return gym.spaces.Dict(OrderedDict((k, s) for k, s in space.spaces.items() if k in self.keys))
        size = sum(int(np.prod(space.spaces[k].shape)) for k in self.keys)
        return gym.spaces.Box(-np.inf, np.inf, (size,), np.float32)

    def __call__(self, obs: ObsDict) -> ObsDict | torch.Tensor:
        if self.per_key:
            return ObsDict({k: obs[k] for k in self.keys}, obs.batch_dims)
        n = obs.shape[0]
        return torch.cat([obs[k].reshape(n, -1).float() for k in self.keys], -1)
