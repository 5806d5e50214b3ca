"""The envpool backend: ``envpool.make(task_id, env_type="gymnasium")`` in sync mode.

envpool auto-resets on the NEXT step (the step after ``done`` ignores the action and returns
the reset obs). We turn that into the same-step contract of :mod:`rlchain.envs.vecenv`: after
a step, the rows that ended keep their last obs in ``final_obs`` and take that auto-reset step
right away (``env.step(noop, env_id=ids)``), whose obs are spliced into ``obs``. It is envpool's
own reset, so Atari's ``episodic_life`` goes on with the next life (``env.reset(ids)`` would
restart the whole game). envpool's ``truncated`` is its time limit (``max_episode_steps``),
``terminated`` the task's own end (with ``episodic_life``: a lost life), as in gymnasium.

Atari tasks also report the game's unclipped reward and the end of the whole game
(``StepResult.game_reward`` / ``game_over``, from envpool's ``info['reward']`` and
``info['terminated']``), so scores are whole games even with ``episodic_life`` / ``reward_clip``.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from rlchain.envs.vecenv import StepResult
from rlchain.envs.wrappers.action_repeat import repeat_step
from rlchain.envs.wrappers.goal_env import fetch_compute_reward
from rlchain.envs.wrappers.spaces import (
    cast_actions,
    cast_obs,
    flatten_dict_obs,
    float32_action_space,
    float32_obs_space,
    step_arrays,
)
from rlchain.errors import optional_import

INSTALL_HINT = "envpool is not installed: pip install rlchain[envpool] (or pip install envpool)"

RESERVED_KEYS = frozenset({"num_envs", "batch_size", "seed", "env_seed", "max_num_players",
                           "gym_reset_return_info", "base_path"})
"""envpool config keys this backend sets itself; env_config may not pass them to envpool.make."""


def import_envpool() -> Any:
    """Import envpool or raise an ImportError that says how to install it."""
    return optional_import("envpool", INSTALL_HINT)


@functools.lru_cache(maxsize=1)
def envpool_tasks() -> frozenset[str]:
    """Every task id envpool knows (``envpool.list_all_envs()``)."""
    return frozenset(import_envpool().list_all_envs())


def envpool_config_keys(task_id: str) -> set[str]:
    """The ``envpool.make`` keyword arguments ``task_id`` accepts from an env_config."""
    return set(import_envpool().make_spec(task_id).config._fields) - RESERVED_KEYS


def random_seed(num_envs: int) -> int:
    """A random seed such that envpool's per-env seeds ``seed + i`` stay in int32."""
    return int(np.random.default_rng().integers(0, 2**31 - 1 - num_envs))


def game_signals(infos: dict, truncated: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(game_reward (N,) float32, game_over (N,) bool) of an Atari step, (None, None) for other tasks.

    envpool's Atari info holds the unclipped ``reward``, ``lives`` and ``terminated`` (the game
    itself is over, not just a life); a time-out (``truncated``) also ends the game.
    """
    if "lives" not in infos or "reward" not in infos or "terminated" not in infos:
        return None, None
    game_over = np.asarray(infos["terminated"]).astype(bool).reshape(-1) | truncated
    return np.asarray(infos["reward"], dtype=np.float32).reshape(-1), game_over


class EnvpoolVecEnv:
    """``num_envs`` envpool envs of ``task_id`` with same-step auto-reset.

    Env i is seeded with ``seed + i`` (envpool's own rule). ``env_kwargs`` go to
    ``envpool.make`` (e.g. ``max_episode_steps``, ``episodic_life``, ``reward_clip``).
    Dict observations (DeepMind Control) are flattened to one float32 vector.
    ``render=True`` creates it with ``render_mode='human'`` (envpool needs opencv-python).

    ``groups`` > 1 splits the envs into that many envpool pools of equal size (rows
    ``env_groups[g]``, env i still seeded ``seed + i``) that step in the background:
    :meth:`send` starts group g's step and returns at once, :meth:`recv` waits for it. A pipelined
    rollout (``algos/ppo/ppo.py``) computes one group's actions while envpool's threads step
    the other, so env stepping overlaps policy inference. :meth:`step` still steps all of them.

    ``action_repeat`` > 1 applies each action for that many env steps (:mod:`rlchain.envs.wrappers.action_repeat`).
    """

    def __init__(self, task_id: str, num_envs: int, seed: int | None = None,
                 env_kwargs: dict | None = None, render: bool = False, groups: int = 1,
                 action_repeat: int = 1) -> None:
        self._envpool = import_envpool()
        if task_id not in envpool_tasks():
            raise ValueError(f"envpool has no task '{task_id}'")
        if groups < 1 or num_envs % groups:
            raise ValueError(f"env_groups {groups} must be >= 1 and divide the number of envs {num_envs}")
        if int(action_repeat) != action_repeat or action_repeat < 1:
            raise ValueError(f"action_repeat must be an integer >= 1, got {action_repeat!r}")
        self.action_repeat = int(action_repeat)
        self._sent: dict[int, np.ndarray] = {}
        self.task_id = task_id
        self.num_envs = num_envs
        size = num_envs // groups
        self.env_groups = [slice(g * size, (g + 1) * size) for g in range(groups)]
        self._kwargs = dict(env_kwargs or {})
        if render:
            self._kwargs["render_mode"] = "human"
        self.pools: list[Any] = []
        self._build(random_seed(num_envs) if seed is None else int(seed))
        self._env_obs_space = self.env.observation_space
        self._env_action_space = self.env.action_space
        self.observation_space = float32_obs_space(self._env_obs_space)
        self.action_space = float32_action_space(self._env_action_space)

    @property
    def env(self) -> Any:
        """The (first) envpool pool."""
        return self.pools[0]

    def _build(self, seed: int) -> None:
        """(Re)create the envpool pools with ``seed``; envpool can only be seeded at creation."""
        self._close_pools()
        for rows in self.env_groups:
            size = rows.stop - rows.start
            self.pools.append(self._envpool.make(self.task_id, env_type="gymnasium", num_envs=size,
                                                 batch_size=size, seed=seed + rows.start, **self._kwargs))
        self._seed = seed
        self._fresh = True  # created with self._seed and not reset yet

    def _obs(self, obs: Any) -> np.ndarray:
        """Batched obs from envpool as a writable float32 (or uint8) array (N, *obs_shape)."""
        if isinstance(obs, dict):
            return flatten_dict_obs(obs, self._env_obs_space).astype(np.float32)
        obs = cast_obs(obs)
        return obs if obs.flags.writeable else obs.copy()

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset all envs; with a seed, env i restarts from ``seed + i`` (rebuilds the pools).

        Returns obs (N, *observation_space.shape).
        """
        if seed is not None and not (self._fresh and int(seed) == self._seed):
            self._build(int(seed))
        self._fresh = False
        obs = [self._obs(pool.reset()[0]) for pool in self.pools]
        return obs[0] if len(obs) == 1 else np.concatenate(obs)

    def step(self, actions: np.ndarray) -> StepResult:
        """Step with actions (N, *action_space.shape); finished envs are reset in the same call."""
        if len(self.pools) == 1:
            actions = cast_actions(actions, self._env_action_space, self.num_envs)
            return self._finish(self.pools[0], *self._repeat(self.pools[0], actions, self.pools[0].step(actions)))
        for g, rows in enumerate(self.env_groups):
            self.send(g, actions[rows])
        return concat_results([self.recv(g) for g in range(len(self.pools))])

    def send(self, group: int, actions: np.ndarray) -> None:
        """Start stepping env group ``group`` (rows ``env_groups[group]``) with its actions; returns at once."""
        rows = self.env_groups[group]
        actions = cast_actions(actions, self._env_action_space, rows.stop - rows.start)
        if self.action_repeat > 1:
            self._sent[group] = actions
        self.pools[group].send(actions)

    def recv(self, group: int) -> StepResult:
        """Wait for the step :meth:`send` started on ``group``; its rows' StepResult (same-step reset)."""
        pool = self.pools[group]
        result = self._finish(pool, *self._repeat(pool, self._sent.pop(group, None), pool.recv()))
        if "env_id" in result.infos:  # envpool numbers the envs of each pool from 0
            result.infos = {**result.infos, "env_id": np.asarray(result.infos["env_id"]) + self.env_groups[group].start}
        return result

    def _repeat(self, pool: Any, actions: np.ndarray | None, first: tuple) -> tuple:
        """``first`` (a pool's raw step) extended by the rest of the action repeat (its later steps
        run here, synchronously, for the envs still in their episode)."""
        if self.action_repeat == 1 or actions is None:
            return first
        return repeat_step(pool.step, actions, first, self.action_repeat)

    def _finish(self, pool: Any, obs: Any, reward: Any, terminated: Any, truncated: Any,
                infos: dict) -> StepResult:
        """A pool's raw step as a StepResult; its finished envs take envpool's auto-reset step now."""
        reward, terminated, truncated = step_arrays(reward, terminated, truncated)
        obs = self._obs(obs)
        final_obs = obs.copy()
        done = terminated | truncated
        game = game_signals(infos, truncated)
        if done.any():
            ids = np.flatnonzero(done).astype(np.int32)
            noop = np.zeros((len(ids), *self._env_action_space.shape), self._env_action_space.dtype)
            new_obs, _, _, _, reset_info = pool.step(noop, ids)  # envpool's auto-reset step
            obs[np.asarray(reset_info["env_id"])] = self._obs(new_obs)
        return StepResult(obs, reward, terminated, truncated, final_obs, infos, *game)

    def compute_reward(self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any = None) -> np.ndarray:
        """Goals (B, G) -> rewards (B,) for envpool's Fetch tasks, which expose no ``compute_reward``:
        gymnasium-robotics' documented Fetch reward (``envs/goal_env.fetch_compute_reward``) with the
        task's ``distance_threshold`` and ``reward_type``. ValueError for other tasks."""
        if not self.task_id.startswith("Fetch"):
            raise ValueError(f"envpool task '{self.task_id}' has no compute_reward: hindsight replay needs a "
                             f"goal env (envpool's Fetch tasks)")
        config = self._envpool.make_spec(self.task_id).config._asdict()
        config.update(self._kwargs)
        return fetch_compute_reward(achieved_goal, desired_goal, info, float(config["distance_threshold"]),
                                    str(config["reward_type"]))

    def render(self) -> Any:
        """Pass-through to envpool's ``render()`` (env 0; needs ``render=True`` at creation)."""
        return self.env.render()

    def _close_pools(self) -> None:
        for pool in self.pools:
            pool.close()
        self.pools = []

    def close(self) -> None:
        """Close the pools."""
        self._close_pools()


def concat_results(results: list[StepResult]) -> StepResult:
    """One StepResult for all envs from the StepResults of consecutive env groups (numpy fields)."""
    def cat(values: list) -> Any:
        return None if values[0] is None else np.concatenate(values)

    infos: dict = {}
    for key in results[0].infos:
        try:
            infos[key] = np.concatenate([np.asarray(r.infos[key]) for r in results])
        except ValueError:  # a scalar or ragged entry: keep the first group's
            infos[key] = results[0].infos[key]
    fields = ("obs", "reward", "terminated", "truncated", "final_obs", "game_reward", "game_over")
    return StepResult(**{f: cat([getattr(r, f) for r in results]) for f in fields}, infos=infos)
