"""Envs for the asymmetric critic: Dict ``{'obs', 'state'}`` observations become one flat vector.

rl_games envs with ``use_central_value = True`` return ``{'obs': actor view, 'state': full state}``.
rlchain concatenates the two per env (``[obs | state]``, float32) so every vecenv backend, the
rollout storage and time-out bootstrapping work unchanged; the space is an :class:`ObsStateBox`
that remembers where ``obs`` ends. The actor model reads ``[..., :obs_size]``, the central value
model ``[..., obs_size:]`` (``ObservationModel.obs_slice``). Both parts are flattened to 1-d with
gymnasium's rule (``gym.spaces.flatten``), so a part may itself be a Dict (rl_games' TestRnnEnv
with ``multi_obs_space``); the box keeps both parts' spaces as the env declared them
(``obs_space`` / ``state_space``) for networks that split a flat part back by key.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

KEYS = frozenset({"obs", "state"})


class ObsStateBox(gym.spaces.Box):
    """A flat float32 Box ``[obs | state]`` that knows the split: ``obs_size`` and ``state_size``,
    and (when known) each part's space before flattening: ``obs_space`` and ``state_space``."""

    def __init__(self, obs_size: int, state_size: int, seed: int | None = None,
                 obs_space: gym.Space | None = None, state_space: gym.Space | None = None) -> None:
        super().__init__(-np.inf, np.inf, (obs_size + state_size,), np.float32, seed=seed)
        self.obs_size, self.state_size = obs_size, state_size
        self.obs_space, self.state_space = obs_space, state_space


def is_obs_state_space(space: gym.Space) -> bool:
    """True for the central-value layout: a Dict with exactly the keys 'obs' and 'state'."""
    return isinstance(space, gym.spaces.Dict) and set(space.spaces) == KEYS


class ConcatObsState(gym.ObservationWrapper):
    """``{'obs': (...), 'state': (...)}`` -> ``[flatten(obs) | flatten(state)]`` as float32."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        spaces = env.observation_space.spaces
        self._obs_space, self._state_space = spaces["obs"], spaces["state"]
        self.observation_space = ObsStateBox(gym.spaces.flatdim(self._obs_space), gym.spaces.flatdim(self._state_space),
                                             obs_space=self._obs_space, state_space=self._state_space)

    def observation(self, observation: dict) -> np.ndarray:
        return np.concatenate([_flat(self._obs_space, observation["obs"]),
                               _flat(self._state_space, observation["state"])])


def _flat(space: gym.Space, value: object) -> np.ndarray:
    """One part as a float32 vector: a Box raveled as is, a Dict (or other space) by gymnasium's rule."""
    if isinstance(space, gym.spaces.Box):
        return np.asarray(value, dtype=np.float32).ravel()
    return np.asarray(gym.spaces.flatten(space, value), dtype=np.float32)


def concat_obs_state_env(env: gym.Env) -> gym.Env:
    """``env`` with ``{'obs', 'state'}`` observations concatenated; other envs unchanged."""
    return ConcatObsState(env) if is_obs_state_space(env.observation_space) else env


def obs_state_split(space: gym.Space) -> int | None:
    """Where the actor's part ends in a vecenv's observations, or None without a central-value state."""
    return getattr(space, "obs_size", None) if isinstance(space, ObsStateBox) else None
