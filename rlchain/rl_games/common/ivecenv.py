"""rl_games' ``IVecEnv``: the vector-env interface an rl_games script's env derives from.

rlchain adapts such an env to its own VecEnv contract (:mod:`rlchain.envs.backends.rl_games_vecenv`):
``reset() -> obs`` and ``step(actions) -> (obs, rewards, dones, infos)`` with batched arrays or torch
tensors, ``get_env_info()`` with the spaces, ``infos['time_outs']`` telling time-outs from terminations.
"""

from __future__ import annotations

from typing import Any


class IVecEnv:
    """Base class of an rl_games vector env; override ``step``, ``reset`` and ``get_env_info``."""

    def step(self, actions: Any) -> tuple[Any, Any, Any, dict]:
        """Step every env with ``actions`` (N, ...); returns (obs, rewards (N,), dones (N,), infos)
        and resets the envs that finished."""
        raise NotImplementedError

    def reset(self) -> Any:
        """Reset every env; returns the observations (N, ...) (or ``{'obs': ..., 'states': ...}``)."""
        raise NotImplementedError

    def has_action_masks(self) -> bool:
        """Whether the env gives action masks (rl_games' name; rlchain reads ``has_action_mask``)."""
        return False

    def get_number_of_agents(self) -> int:
        """Agents per env (their rows are flattened into the batch)."""
        return 1

    def get_env_info(self) -> dict:
        """``{'observation_space', 'action_space'}`` and optionally ``state_space``, ``agents``, ``value_size``."""
        return {}

    def seed(self, seed: int) -> None:
        """Reseed the envs (rl_games calls it rarely; the creator usually seeds)."""

    def set_train_info(self, env_frames: int, *args: Any, **kwargs: Any) -> None:
        """Told at the start of each epoch how many env frames training has seen (curricula)."""

    def get_env_state(self) -> Any:
        """Serializable env state for a checkpoint (curricula); None when the env keeps none."""
        return None

    def set_env_state(self, env_state: Any) -> None:
        """Restore what :meth:`get_env_state` returned."""
