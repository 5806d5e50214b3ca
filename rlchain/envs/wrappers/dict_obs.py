"""Dict observation spaces: flattened into one vector in the vecenv layer, split back by key on demand.

Every backend hands the trainer one flat observation per env: a gymnasium ``Dict`` observation
space is flattened with gymnasium's own rule (``gym.spaces.flatten``: keys in the space's order,
which gymnasium sorts; Box entries raveled, Discrete entries one-hot). Storage, input
normalization and the built-in networks then work unchanged.

Routing by key: a network that wants the entries apart (e.g. an image through a CNN, a vector
through an MLP) receives the flat vector and splits it back with :func:`split_flat_obs` and the
env's Dict space, which its builder gets as the ``observation_space`` keyword (the flat space is a
:class:`FlatDictBox` that keeps it)::

    parts = split_flat_obs(input_dict["obs"], observation_space)   # {'image': (B, 3, 8, 8), 'pos': (B, 2)}

A backend that knows its Dict layout may declare the flat space as a :class:`FlatDictBox`, which
carries the Dict (``dict_space``) for the network (e.g. rl_games' ``use_dict_obs_space``, see
:mod:`rlchain.envs.wrappers.reward_action_obs`).

With ``normalize_input`` the running mean/std is per flat dimension, i.e. per entry of every key.
The asymmetric-critic layout ``{'obs', 'state'}`` (``use_central_value``) is not flattened here.

A network that takes the keys apart (``multi_input``) gets them per key again: :class:`PerKeyObs` splits
the flat observations back into ``{key: array}`` in each key's dtype before they reach the trainer, which
keeps them per key from there (rlchain/envs/obs_dict.py).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from rlchain.envs.obs_dict import CENTRAL_VALUE_KEYS, ObsDict, discrete_layout, is_dict_space, is_discrete
from rlchain.envs.spec import declares_state
from rlchain.envs.tensors import is_tensor

if TYPE_CHECKING:  # torch is imported where it is used: a Ray env worker of numpy envs never needs it
    import torch


def should_flatten(space: gym.Space) -> bool:
    """True for a Dict observation space other than the central-value ``{'obs', 'state'}`` one."""
    return isinstance(space, gym.spaces.Dict) and set(space.spaces) != CENTRAL_VALUE_KEYS


class FlatDictBox(gym.spaces.Box):
    """The flat Box of a flattened Dict observation space that remembers it: ``dict_space`` (key
    order = layout order), so a network can split the observations by key (:func:`split_flat_obs`).
    ``dtype`` defaults to the flattened space's."""

    def __init__(self, dict_space: gym.spaces.Dict, dtype: type | np.dtype | None = None,
                 seed: int | None = None) -> None:
        flat = gym.spaces.flatten_space(dict_space)
        dtype = np.dtype(dtype or flat.dtype)
        super().__init__(flat.low.astype(dtype), flat.high.astype(dtype), flat.shape, dtype, seed=seed)
        self.dict_space = dict_space


def flatten_dict_env(env: gym.Env) -> gym.Env:
    """``env`` with Dict observations flattened (gymnasium's FlattenObservation, its space a
    :class:`FlatDictBox`); others unchanged."""
    if not should_flatten(env.observation_space):
        return env
    flat = gym.wrappers.FlattenObservation(env)
    flat.observation_space = FlatDictBox(env.observation_space)
    return flat


def split_flat_obs(obs: torch.Tensor, space: gym.spaces.Dict) -> dict[str, torch.Tensor]:
    """Flat observations (B, flatdim(space)) -> {key: (B, *shape)} views, in the order of ``space``.

    Box entries get their shape back; other entries (e.g. one-hot Discrete) stay flat (B, flatdim).
    """
    total = int(gym.spaces.flatdim(space))
    if obs.shape[-1] != total:
        raise ValueError(f"flat observations have {obs.shape[-1]} values, the Dict space flattens to {total}")
    out, start = {}, 0
    for key, sub in space.spaces.items():
        size = int(gym.spaces.flatdim(sub))
        part = obs[:, start:start + size]
        if isinstance(sub, gym.spaces.Box):
            part = part.reshape(obs.shape[0], *sub.shape)
        out[key] = part
        start += size
    return out



def from_one_hot(flat: torch.Tensor, space: gym.spaces.Discrete | gym.spaces.MultiDiscrete) -> torch.Tensor:
    """gymnasium's one-hot flattening of a Discrete / MultiDiscrete entry (N, sum of sizes) -> its values, int64
    (N,) or (N, *nvec.shape), ``start`` added back."""
    if isinstance(space, gym.spaces.Discrete):
        return flat.argmax(-1) + int(space.start)
    import torch

    sizes, starts, _ = discrete_layout(space)
    values = torch.stack([part.argmax(-1) for part in flat.split(sizes.tolist(), -1)], -1)
    return (values + torch.as_tensor(starts, device=flat.device)).reshape(flat.shape[0], *space.nvec.shape)


class PerKeyObs:
    """A VecEnv whose Dict observations some backend flattened (its space a :class:`FlatDictBox`), handed on
    per key again: ``observation_space`` is the Dict, ``reset`` / ``step`` give ``{key: (N, *shape)}``
    arrays (an ObsDict for a tensor env) in each key's dtype (a Discrete key's int64 value, not its one-hot), so a
    multi-input network gets them apart and the rollout stores a uint8 image as uint8 (the flat float32 vector
    lives only for the step; 0..255 is exact in it). Everything else is the wrapped env's. Env groups are not
    pipelined through it."""

    env_groups = None

    def __init__(self, env: Any) -> None:
        self.env = env
        self.observation_space = env.observation_space.dict_space
        if not is_dict_space(self.observation_space):
            raise ValueError(f"Dict observations kept per key need Box, Discrete or MultiDiscrete entries, the env "
                             f"has {self.observation_space}")

    def __getattr__(self, name: str) -> Any:
        if name == "env":  # not set yet (unpickling): no recursion
            raise AttributeError(name)
        return getattr(self.env, name)

    def split(self, obs: Any) -> dict[str, Any]:
        """Flat (N, D) observations -> {key: (N, *shape)} in each key's dtype (a one-hot Discrete key back to its
        int64 value)."""
        import torch  # the flat vector is split as a tensor, numpy observations too

        flat = obs if is_tensor(obs) else torch.as_tensor(np.asarray(obs))
        out = split_flat_obs(flat, self.observation_space)
        for key, sub in self.observation_space.spaces.items():
            if is_discrete(sub):
                out[key] = from_one_hot(out[key], sub)
            elif np.dtype(sub.dtype) == np.uint8:
                out[key] = out[key].round().to(torch.uint8)
            elif out[key].dtype != torch.float32:
                out[key] = out[key].float()
        return ObsDict(out) if is_tensor(obs) else {k: v.numpy() for k, v in out.items()}

    def reset(self, *args: Any, **kwargs: Any) -> dict[str, Any]:
        return self.split(self.env.reset(*args, **kwargs))

    def step(self, actions: Any) -> Any:
        result = self.env.step(actions)
        return dataclasses.replace(result, obs=self.split(result.obs), final_obs=self.split(result.final_obs))

    def close(self) -> None:
        self.env.close()


class StatefulPerKeyObs(PerKeyObs):
    """:class:`PerKeyObs` over an env that gives its state (``get_state`` / ``set_state``, exact resume): the
    wrapper holds no state of its own, so the wrapped env's is the whole of it. A separate class because the
    env spec reads the state methods from the class, and a :class:`PerKeyObs` over an env without them must
    not claim them."""

    def get_state(self) -> Any:
        return self.env.get_state()

    def set_state(self, state: Any) -> None:
        self.env.set_state(state)


def per_key_obs(env: Any) -> PerKeyObs:
    """``env`` (its observation space a :class:`FlatDictBox`) handed on per key, its state methods kept."""
    return StatefulPerKeyObs(env) if declares_state(env) else PerKeyObs(env)
