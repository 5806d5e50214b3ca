"""Multi-agent envs: ``A = get_number_of_agents()`` agents per env, flattened into the batch.

The contract of a multi-agent env (one env, gymnasium-like, rl_games' names)::

    get_number_of_agents() -> A                     # > 1 makes the factory use this adapter
    observation_space, action_space                 # ONE agent's spaces
    reset(seed=None) -> obs (A, *obs_shape)  or  (obs, info)
    step(actions (A, *action_shape)) -> (obs (A, ...), rewards (A,), terminated, truncated, info)
                                     or (obs, rewards, done, info)             # rl_games' 4-tuple

Dones are per env: the agents of one env end together. ``terminated`` / ``truncated`` are one
bool each, or (A,) arrays whose entries agree (anything else is an error naming the env), and
the env is reset (with every agent) when it ends. A Dict observation space is flattened per agent
(gymnasium's rule); the central-value layout ``{'obs', 'state'}`` becomes ``[obs | state]`` per
agent with an :class:`~rlchain.envs.wrappers.central_value.ObsStateBox` space, as for single-agent envs.
The spec's ``max_episode_steps`` (or ``env_config.max_episode_steps``) truncates episodes.

:class:`MultiAgentVecEnv` turns ``num_actors`` such envs into the VecEnv contract of
:mod:`rlchain.envs.vecenv` with ``num_envs = num_actors * A`` rows, env-major: row ``i * A + j``
is agent ``j`` of env ``i``. Rewards are per agent, so the trainer's episode statistics are per
agent (what rl_games reports); done flags are broadcast to the env's agents; ``final_obs`` holds
each agent's last observation. ``num_envs`` already counts the agents: ``num_agents`` and
``get_number_of_agents()`` say how many rows one env holds, never multiply by them again.
The envs run in this process (``vecenv_type`` auto or sync).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import load_env_creator

from rlchain.config.errors import ConfigError
from rlchain.envs.vecenv import StepResult, close_env
from rlchain.envs.wrappers.central_value import ObsStateBox, is_obs_state_space
from rlchain.envs.wrappers.spaces import cast_actions, cast_obs, float32_action_space, float32_obs_space


def agents_of(env: Any) -> int:
    """``env.get_number_of_agents()`` (looked up through gymnasium wrappers), 1 when it has none."""
    fn = getattr(env, "get_number_of_agents", None)
    if fn is None and hasattr(env, "unwrapped"):
        fn = getattr(env.unwrapped, "get_number_of_agents", None)
    return int(fn()) if callable(fn) else 1


def create_env(env_id: str, kwargs: dict, render: bool = False) -> tuple[Any, int | None]:
    """One env of gymnasium id ``env_id`` from its entry point, without gymnasium's wrappers (they
    check single-agent shapes); returns (env, max_episode_steps of the spec or ``kwargs``)."""
    spec = gym.spec(env_id)
    kwargs = {**spec.kwargs, **kwargs}
    limit = kwargs.pop("max_episode_steps", spec.max_episode_steps)
    if render:
        kwargs["render_mode"] = "human"
    creator = load_env_creator(spec.entry_point) if isinstance(spec.entry_point, str) else spec.entry_point
    return creator(**kwargs), limit


def make_multi_agent_env(env_id: str, num_envs: int, kwargs: dict, seed: int | None, vecenv_type: str,
                         render: bool = False) -> MultiAgentVecEnv | None:
    """A :class:`MultiAgentVecEnv` when ``env_id`` has more than one agent, else None.

    An entry point that is a class without ``get_number_of_agents`` is known to be single-agent
    without building it; otherwise one env is built to ask (and kept as env 0).
    """
    entry = gym.spec(env_id).entry_point
    target = load_env_creator(entry) if isinstance(entry, str) else entry
    if isinstance(target, type) and not hasattr(target, "get_number_of_agents"):
        return None
    first, limit = create_env(env_id, kwargs)
    agents = agents_of(first)
    # gymnasium's vector envs hold one float reward per env: vector rewards (value_size > 1) step here
    in_process = agents > 1 or int(getattr(first, "value_size", 1)) > 1
    if not in_process or vecenv_type not in ("auto", "sync") or render:
        close_env(first)
    if not in_process:
        return None
    if vecenv_type not in ("auto", "sync"):
        raise ConfigError("", "params.config.vecenv_type", f"must be auto or sync, not {vecenv_type}: "
                          f"'{env_id}' is a multi-agent or multi-reward env ({agents} agents), stepped "
                          "in-process")
    if render:  # only env 0 is drawn; the probe was built without a window
        first = create_env(env_id, kwargs, render=True)[0]
    envs = [first] + [create_env(env_id, kwargs)[0] for _ in range(num_envs - 1)]
    return MultiAgentVecEnv(envs, max_episode_steps=limit, seed=seed)


class MultiAgentVecEnv:
    """``len(envs)`` multi-agent envs as one VecEnv of ``len(envs) * A`` rows (see the module doc).

    ``envs`` are built envs of one kind; ``seed`` is used by the first ``reset()`` given none.
    Self-play envs may define ``set_opponent(policy)`` and ``pop_scores()``; they are forwarded.
    """

    def __init__(self, envs: Sequence[Any], max_episode_steps: int | None = None,
                 seed: int | None = None) -> None:
        if not envs:
            raise ValueError("MultiAgentVecEnv needs at least one env")
        self.envs = list(envs)
        self.num_agents = agents_of(self.envs[0])
        self.num_actors = len(self.envs)
        self.num_envs = self.num_actors * self.num_agents
        self.max_episode_steps = max_episode_steps
        self._seed = seed
        self._steps = np.zeros(self.num_actors, dtype=np.int64)
        first = self.envs[0]
        self._env_obs_space = first.observation_space
        self._env_action_space = first.action_space
        space = first.observation_space
        self._obs_state = is_obs_state_space(space)
        self.observation_space = ObsStateBox(gym.spaces.flatdim(space["obs"]), gym.spaces.flatdim(space["state"])) \
            if self._obs_state else float32_obs_space(space)
        self.action_space = float32_action_space(first.action_space)
        self.value_size = 1
        for attr in ("value_size", "use_central_value", "concat_infos"):
            value = getattr(first, attr, None)
            if value is not None:
                setattr(self, attr, value)

    def get_number_of_agents(self) -> int:
        """Agents per env (rows per env of this VecEnv; ``num_envs`` already includes them)."""
        return self.num_agents

    # ----- reset / step ---------------------------------------------------------------------
    def reset(self, seed: int | None = None) -> Any:
        """Reset every env (env i with ``seed + i`` when it takes a seed); obs (N * A, *obs_shape)."""
        if seed is None:
            seed, self._seed = self._seed, None
        self._steps[:] = 0
        return self._stack([self._reset_one(i, None if seed is None else seed + i)
                            for i in range(self.num_actors)])

    def step(self, actions: Any) -> StepResult:
        """Step every env with its agents' rows of ``actions`` (N * A, *action_shape); finished envs
        are reset in the same call."""
        a = self.num_agents
        actions = cast_actions(actions, self._env_action_space, self.num_envs)
        obs_list, final_list, infos = [], [], []
        rewards = np.zeros((self.num_envs, self.value_size) if self.value_size > 1 else self.num_envs,
                           dtype=np.float32)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        self._steps += 1
        for i, env in enumerate(self.envs):
            rows = slice(i * a, (i + 1) * a)
            obs, reward, term, trunc, info = _split_step(env.step(_rows(actions, rows)))
            rewards[rows] = _per_agent_reward(reward, a, i, self.value_size)
            term, trunc = _per_env_done(term, trunc, a, i)
            if self.max_episode_steps is not None and self._steps[i] >= self.max_episode_steps:
                trunc = trunc | ~term
            terminated[rows], truncated[rows] = term, trunc
            final_list.append(obs)
            obs_list.append(self._reset_one(i, None) if bool(term.any() or trunc.any()) else obs)
            infos.append(info)
        return StepResult(self._stack(obs_list), rewards, terminated, truncated, self._stack(final_list),
                          {"env_infos": infos})

    def _reset_one(self, i: int, seed: int | None) -> Any:
        env = self.envs[i]
        self._steps[i] = 0
        takes_seed = "seed" in inspect.signature(env.reset).parameters
        out = env.reset(seed=seed) if takes_seed and seed is not None else env.reset()
        if isinstance(out, tuple) and len(out) == 2 and isinstance(out[1], dict):
            out = out[0]  # gymnasium's (obs, info)
        return out

    def _stack(self, per_env: list[Any]) -> Any:
        """Per-env observations (A, ...) -> the batch (N * A, ...) as the trainer sees it."""
        a = self.num_agents
        if self._obs_state:  # [obs | state] per agent
            return np.concatenate([np.concatenate([np.asarray(o["obs"], dtype=np.float32).reshape(a, -1),
                                                   np.asarray(o["state"], dtype=np.float32).reshape(a, -1)], axis=1)
                                   for o in per_env])
        if isinstance(self._env_obs_space, gym.spaces.Dict):
            space = self._env_obs_space
            return cast_obs(np.stack([gym.spaces.flatten(space, {k: np.asarray(o[k])[j] for k in space.spaces})
                                      for o in per_env for j in range(a)]))
        return cast_obs(np.concatenate([np.asarray(o).reshape(a, *self._env_obs_space.shape)
                                        for o in per_env]))

    # ----- optional rl_games / self-play methods --------------------------------------------
    def has_action_mask(self) -> bool:
        fn = getattr(self.envs[0], "has_action_mask", None)
        return bool(fn()) if callable(fn) else False

    def get_action_mask(self) -> np.ndarray:
        """(N * A, mask_size) bool: each env's (A, mask_size) masks stacked."""
        return np.concatenate([np.asarray(env.get_action_mask(), dtype=bool).reshape(self.num_agents, -1)
                               for env in self.envs])

    def set_opponent(self, policy: Callable[[np.ndarray], np.ndarray], env_ids: Sequence[int] | None = None) -> None:
        """Self-play: give envs ``env_ids`` (all when None; env indices, not rows) a new opponent."""
        for i in range(self.num_actors) if env_ids is None else env_ids:
            self.envs[i].set_opponent(policy)

    def pop_scores(self) -> np.ndarray:
        """Self-play: scores of the games finished since the last call, from every env."""
        return np.concatenate([np.asarray(env.pop_scores(), dtype=np.float64).reshape(-1) for env in self.envs])

    def render(self) -> Any:
        return self.envs[0].render()

    def close(self) -> None:
        for env in self.envs:
            close_env(env)


def _split_step(out: tuple) -> tuple[Any, Any, np.ndarray, np.ndarray, dict]:
    """gymnasium's 5-tuple or rl_games' 4-tuple (done, info['time_outs'] / 'TimeLimit.truncated')."""
    if len(out) == 5:
        obs, reward, term, trunc, info = out
        return obs, reward, np.asarray(term, dtype=bool), np.asarray(trunc, dtype=bool), info or {}
    obs, reward, done, info = out
    info = info or {}
    timeout = np.asarray(info.get("time_outs", info.get("TimeLimit.truncated", False)), dtype=bool)
    done = np.asarray(done, dtype=bool)
    return obs, reward, done & ~timeout, done & timeout, info


def _rows(actions: Any, rows: slice) -> Any:
    return tuple(col[rows] for col in actions) if isinstance(actions, tuple) else actions[rows]


def _per_agent_reward(reward: Any, agents: int, index: int, value_size: int = 1) -> np.ndarray:
    """(A,) rewards, or (A, value_size) for multi-head values; one reward (vector) is shared."""
    if value_size > 1:
        reward = np.asarray(reward, dtype=np.float32).reshape(-1, value_size)
        if reward.shape[0] not in (1, agents):
            raise ValueError(f"env {index} returned rewards of shape {reward.shape}; expected "
                             f"({value_size},) or ({agents}, {value_size}) for value_size {value_size}")
        return np.broadcast_to(reward, (agents, value_size))
    reward = np.asarray(reward, dtype=np.float32).reshape(-1)
    if reward.size == 1:
        return np.repeat(reward, agents)
    if reward.size != agents:
        raise ValueError(f"multi-agent env {index} returned {reward.size} rewards for {agents} agents")
    return reward


def _per_env_done(term: np.ndarray, trunc: np.ndarray, agents: int, index: int) -> tuple[np.ndarray, np.ndarray]:
    """One done per env, broadcast to its agents; per-agent flags must agree on whether it ended."""
    term = np.broadcast_to(term.reshape(-1), (agents,)) if term.size == 1 else term.reshape(-1)
    trunc = np.broadcast_to(trunc.reshape(-1), (agents,)) if trunc.size == 1 else trunc.reshape(-1)
    done = term | trunc
    if done.any() and not done.all():
        raise ValueError(f"multi-agent env {index}: agents of one env must end together, got dones "
                         f"{done.astype(int).tolist()}")
    return term.copy(), trunc.copy()
