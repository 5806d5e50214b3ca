"""The gymnasium backend: one gymnasium id, vectorized by gymnasium's own vector API.

Modes:

- ``native``: the id's ``vector_entry_point`` (e.g. CartPole-v1: one numpy env for the whole
  batch, faster than ``sync``'s env per row). Only used when the result has same-step auto-reset: the
  vector env declares ``AutoresetMode.SAME_STEP``, or it is a NEXT_STEP env we know how to reset
  row-wise right after the step (see ``_SAME_STEP_RESETTERS``).
- ``sync``: ``SyncVectorEnv`` with ``AutoresetMode.SAME_STEP``, one process.
- ``async``: ``AsyncVectorEnv`` with ``AutoresetMode.SAME_STEP``, one subprocess per env.
- ``auto``: ``native`` when available for this id and kwargs (and not rendering, and more than one env), else
  ``sync``.

Action masks: sub-envs' ``has_action_mask()`` / ``get_action_mask()`` are queried with the vector
env's ``call`` (native: the vector env's own methods); Dict observations are flattened per sub-env
(see :mod:`rlchain.envs.wrappers.action_masks`, :mod:`rlchain.envs.wrappers.dict_obs`).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import load_env_creator
from gymnasium.vector import AutoresetMode

from rlchain.envs.vecenv import StateUnavailable, StepResult
from rlchain.envs.wrappers import gym_state
from rlchain.envs.wrappers.action_masks import vector_action_mask, vector_has_action_mask
from rlchain.envs.wrappers.spaces import (
    call_indexed,
    cast_actions,
    cast_obs,
    float32_action_space,
    float32_obs_space,
    make_indexed,
    step_arrays,
)

MODES = ("auto", "native", "sync", "async")


def _reset_cartpole_rows(env: Any, done: np.ndarray, obs: np.ndarray) -> None:
    """Reset the ``done`` rows of a NEXT_STEP ``CartPoleVectorEnv`` now and write their obs.

    Does exactly what the env itself would do at the start of its next step (uniform state in
    [low, high], step counter 0) and clears its pending-reset flag so that step is a normal one.
    """
    new = env.np_random.uniform(low=env.low, high=env.high, size=(4, int(done.sum())))
    env.state[:, done] = new
    env.steps[done] = 0
    env.prev_done[done] = False
    obs[done] = new.T


def _resetters() -> dict[type, Callable[[Any, np.ndarray, np.ndarray], None]]:
    """Known NEXT_STEP native vector envs and how to reset some of their rows (class -> fn)."""
    from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv
    return {CartPoleVectorEnv: _reset_cartpole_rows}


def native_vector_class(env_id: str, env_kwargs: dict | None = None) -> type | None:
    """The native vector env class usable with same-step resets for ``env_id``, else None.

    None when the id has no vector entry point, its autoreset can't be made same-step, or it
    does not take all of ``env_kwargs`` (those go to its constructor).
    """
    spec = gym.spec(env_id)
    if spec.vector_entry_point is None or spec.additional_wrappers:
        return None
    try:
        cls = load_env_creator(spec.vector_entry_point) if isinstance(spec.vector_entry_point, str) \
            else spec.vector_entry_point
    except Exception:  # e.g. the jax-based phys2d envs without jax installed
        return None
    mode = getattr(cls, "metadata", {}).get("autoreset_mode")
    if mode != AutoresetMode.SAME_STEP and cls not in _resetters():
        return None
    params = inspect.signature(cls).parameters
    if not any(p.kind == p.VAR_KEYWORD for p in params.values()):
        if any(k not in params for k in {**spec.kwargs, **(env_kwargs or {})}):
            return None
    return cls


class GymnasiumVecEnv:
    """A batch of ``num_envs`` copies of gymnasium env ``env_id`` with same-step auto-reset.

    ``env_kwargs`` go to ``gym.make`` (e.g. ``max_episode_steps``) or to the native vector env.
    ``render=True`` creates the envs with ``render_mode='human'`` (sync only). ``seed`` is used
    by the first ``reset()`` that is given no seed. ``env_fns`` (``num_envs`` zero-argument env factories,
    e.g. a user's env objects from Python) replace ``gym.make(env_id)``; ``env_id`` then only names them, and
    they step in this process (sync, or async when asked).
    """

    def __init__(self, env_id: str, num_envs: int, mode: str = "auto", env_kwargs: dict | None = None,
                 render: bool = False, seed: int | None = None, env_fns: list[Callable[[], Any]] | None = None) -> None:
        if mode not in MODES:
            raise ValueError(f"unknown gymnasium vectorization mode '{mode}' (choices: {', '.join(MODES)})")
        kwargs = dict(env_kwargs or {})
        if env_fns is not None and (len(env_fns) != num_envs or kwargs or mode == "native"):
            raise ValueError(f"'{env_id}': env_fns takes {num_envs} factories, no env_kwargs and mode sync or async")
        native = native_vector_class(env_id, kwargs) if env_fns is None else None
        if mode == "native" and (native is None or render):
            why = "rendering needs sync" if render else "no same-step native vector env for these kwargs"
            raise ValueError(f"'{env_id}' can't use the native gymnasium vector env: {why}")
        if mode == "auto":  # one env: the plain env steps in half the native vector env's time (CartPole)
            mode = "native" if native is not None and not render and num_envs > 1 else "sync"
        if render:
            kwargs["render_mode"] = "human"
        self.mode = mode
        self.num_envs = num_envs
        self.env_id = env_id
        self._goal_env: Any = None  # a copy of one env for compute_reward (hindsight replay)
        self._goal_kwargs = {k: v for k, v in kwargs.items() if k != "render_mode"}
        self._seed = seed
        self._reset_rows = None
        self._has_mask: bool | None = None
        if mode == "native":
            self.env = gym.make_vec(env_id, num_envs, vectorization_mode="vector_entry_point", **kwargs)
            if self.env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
                self._reset_rows = _resetters()[type(self.env.unwrapped)]
        else:
            fns = [functools.partial(make_indexed, env_id, i, kwargs) for i in range(num_envs)] if env_fns is None \
                else [functools.partial(call_indexed, make, i) for i, make in enumerate(env_fns)]
            vector_cls = gym.vector.SyncVectorEnv if mode == "sync" else gym.vector.AsyncVectorEnv
            self.env = vector_cls(fns, autoreset_mode=AutoresetMode.SAME_STEP)
        self._env_action_space = self.env.single_action_space
        self.observation_space = float32_obs_space(self.env.single_observation_space)
        self.action_space = float32_action_space(self.env.single_action_space)

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset all envs; env i gets ``seed + i`` (native: one batch RNG seeded with ``seed``).

        Returns obs (N, *observation_space.shape).
        """
        if seed is None:
            seed, self._seed = self._seed, None
        obs, _ = self.env.reset(seed=seed)
        return cast_obs(obs)

    def step(self, actions: np.ndarray) -> StepResult:
        """Step with actions (N, *action_space.shape); finished envs are reset in the same call."""
        actions = cast_actions(actions, self._env_action_space, self.num_envs)
        obs, reward, terminated, truncated, infos = self.env.step(actions)
        reward, terminated, truncated = step_arrays(reward, terminated, truncated)
        obs = cast_obs(obs)
        if not obs.flags.writeable:
            obs = obs.copy()
        final_obs = obs.copy()
        done = terminated | truncated
        if done.any():
            if self._reset_rows is not None:  # obs holds the last obs; reset those rows now
                self._reset_rows(self.env.unwrapped, done, obs)
            else:  # obs already holds the next episode's first obs
                mask = infos.pop("_final_obs")
                final_obs[mask] = cast_obs(np.stack(infos.pop("final_obs")[mask]))
        return StepResult(obs, reward, terminated, truncated, final_obs, infos)

    def get_state(self) -> dict[str, Any]:
        """Every env's state (:mod:`rlchain.envs.wrappers.gym_state`): the native vector env's own,
        else each sub-env's, read through the vector env (in the workers for async)."""
        if self.mode == "native":
            return {"mode": "native", "vector": gym_state.snapshot(self.env, f"{self.env_id} vector env"),
                    "seed": self._seed}
        states = list(self.env.get_attr("rlchain_state"))
        for state in states:
            if isinstance(state, Exception):
                raise StateUnavailable(f"{self.env_id}: {state}")
        return {"mode": "per_env", "envs": states, "seed": self._seed}

    def set_state(self, state: dict[str, Any]) -> None:
        """Put back :meth:`get_state`'s result (sync and async sub-envs share one format)."""
        native = self.mode == "native"
        if (state["mode"] == "native") != native or (not native and len(state["envs"]) != self.num_envs):
            saved = "native" if state["mode"] == "native" else f"{len(state['envs'])} sub-envs"
            raise ValueError(f"{self.env_id}: the saved env state is for {saved}, this env is "
                             f"{'native' if native else f'{self.num_envs} {self.mode} sub-envs'}")
        if native:
            gym_state.restore(self.env, state["vector"], f"{self.env_id} vector env")
        else:
            self.env.set_attr("rlchain_state", state["envs"])
        self._seed = state["seed"]

    def has_action_mask(self) -> bool:
        """Whether the envs define ``has_action_mask()`` returning True (rl_games' name)."""
        if self._has_mask is None:
            self._has_mask = vector_has_action_mask(self.env, self.mode == "native")
        return self._has_mask

    def get_action_mask(self) -> np.ndarray:
        """(N, mask_size) bool masks of the envs' current states (see :mod:`rlchain.envs.wrappers.action_masks`)."""
        return vector_action_mask(self.env, self.mode == "native", self.num_envs)

    def render(self) -> Any:
        """Pass-through to the vector env's ``render()`` (frames for ``human`` mode are drawn)."""
        return self.env.render()

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None) -> np.ndarray:
        """The env's own ``compute_reward`` (gymnasium-robotics goal envs), batched: goals (B, G) -> (B,)
        float32. Evaluated on one extra copy of the env, so it works in every vectorization mode."""
        if self._goal_env is None:
            envs = getattr(self.env, "envs", None)
            if self.env_id not in gym.registry and envs:  # an env object or a factory (no id to make a copy of):
                self._goal_env, self._goal_env_own = envs[0].unwrapped, False  # its compute_reward, a pure function
            else:
                self._goal_env, self._goal_env_own = gym.make(self.env_id, **self._goal_kwargs).unwrapped, True
            if not callable(getattr(self._goal_env, "compute_reward", None)):
                self.close_goal_env()
                raise ValueError(f"'{self.env_id}' has no compute_reward: hindsight replay needs a goal env")
        return np.asarray(self._goal_env.compute_reward(achieved_goal, desired_goal, info), dtype=np.float32)

    def close(self) -> None:
        """Close the envs (and the worker processes in async mode)."""
        self.env.close()
        self.close_goal_env()

    def close_goal_env(self) -> None:
        """Close the copy of one env made for ``compute_reward`` (not a vector env's own env it borrowed)."""
        if self._goal_env is not None and getattr(self, "_goal_env_own", True):
            self._goal_env.close()
        self._goal_env = None
