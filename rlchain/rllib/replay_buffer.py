"""``algo.local_replay_buffer`` (DQN, SAC): rlchain's replay buffer read as RLlib's ``PrioritizedEpisodeReplayBuffer``.

RLlib keeps whole episodes; rlchain keeps transitions, one row per env and step, in a ring. :func:`buffer_state`
takes the rows apart again into RLlib's ``get_state()`` structure, as plain data (numpy arrays, lists, numbers,
strings; nothing pickled), so RLlib's callbacks page example (``ormsgpack.packb(buffer.get_state(),
option=OPT_SERIALIZE_NUMPY)``) writes it:

- ``episodes``: one ``SingleAgentEpisode.get_state()`` dict per episode, oldest first (``observations`` one more
  than ``actions`` / ``rewards``, each ``{"data", "lookback", "finalized", "space"}``; ``is_terminated``,
  ``is_truncated``, ``t_started`` 0, ``t``). The rows of each env are read in the order they were written (the
  newest row of a vectorized step is the last env's). Where the ring has overwritten an episode's start, that
  episode is left out, as RLlib evicts whole episodes. With ``n_step > 1`` the rows hold n-step returns: the
  one-step rewards are recovered from them backwards (each row's discount gives the steps it summed), and the
  n - 1 newest steps, not yet rows, come from the buffer's pending window. rlchain keeps no infos: each episode's
  ``infos`` are empty dicts.
- ``episode_id_to_index``, ``_num_episodes_evicted``, ``_indices`` (``(episode index, timestep, tree index)``
  per stored row; the tree index is the row), ``_num_timesteps``, ``_num_timesteps_added`` (env steps sampled),
  ``sampled_timesteps`` (updates x ``train_batch_size``).
- prioritized: ``_sum_segment`` / ``_min_segment`` (heap arrays, root at 1, the leaf of row i at ``size + i``;
  RLlib's trees are twice as wide), ``_max_priority``, ``_max_idx``, ``_free_nodes``,
  ``_tree_idx_to_sample_idx``, ``_last_sampled_indices`` (empty).
"""

from __future__ import annotations

import math
import uuid
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.rllib.utils.serialization import gym_space_to_dict


def _np(x: Any) -> Any:
    """A tensor (or a dict of tensors) as numpy on the CPU (a CPU tensor's own memory: no copy)."""
    if isinstance(x, dict):
        return {k: _np(v) for k, v in x.items()}
    return x.detach().cpu().numpy()


def _steps_used(discounts: np.ndarray, gamma: float, n_step: int) -> np.ndarray:
    """How many env steps each row's return sums (its discount is gamma ** steps)."""
    if n_step == 1:
        return np.ones(len(discounts), dtype=np.int64)
    if not 0.0 < gamma < 1.0:
        raise ValueError(f"local_replay_buffer.get_state(): with n_step {n_step} and gamma {gamma} the face cannot "
                         f"take its n-step rows apart into steps (gamma must be in (0, 1))")
    steps = np.rint(np.log(np.maximum(discounts.astype(np.float64), 1e-300)) / math.log(gamma)).astype(np.int64)
    return np.clip(steps, 1, n_step)


class _EnvSteps:
    """One env's steps in the order taken, as arrays: its stored rows (oldest first; ``rows`` index the buffer),
    then the pending window's steps (``n_step > 1``: not yet rows). The observations stay in the buffer (and the
    pending steps) until an episode gathers its own: each is copied once."""

    def __init__(self, rows: np.ndarray, at: np.ndarray, cols: dict[str, np.ndarray], pending: list[dict[str, Any]],
                 env: int, gamma: float) -> None:
        self.rows, self.stored = rows, len(rows)
        self.pending = [{k: _pick(v, env) for k, v in step.items()} for step in pending]
        self.at = np.concatenate([at, np.arange(len(pending)) + (int(at[-1]) + 1 if len(at) else 0)])
        flag = lambda name: np.concatenate([cols[name][rows], [bool(p[name]) for p in self.pending]]).astype(bool)  # noqa: E731
        self.term, self.trunc = flag("terminated"), flag("truncated")
        self.used = np.concatenate([cols["used"][rows], np.ones(len(pending), np.int64)]).astype(np.int64)
        self.rewards = _one_step_rewards(np.concatenate([cols["rewards"][rows].astype(np.float64),
                                                         [float(p["rewards"]) for p in self.pending]]),
                                         self.used, gamma)
        self.ends = (self.used == 1) & (self.term | self.trunc)

    def episodes(self, wrapped: bool) -> list[tuple[int, int]]:
        """(start, stop) of each episode; a first one whose start the ring overwrote is left out."""
        cuts = [0, *(np.flatnonzero(self.ends) + 1).tolist()]
        if cuts[-1] < len(self.ends):
            cuts.append(len(self.ends))
        spans = list(zip(cuts, cuts[1:]))
        if wrapped and len(spans) > 1 and self.stored > 0:
            spans = spans[1:]
        return spans

    def gather(self, src: Any, key: str, start: int, stop: int, final: Any = None) -> Any:
        """Column ``key`` (``src``: the buffer's, as numpy) of steps ``start:stop``, then ``final`` when given."""
        extra = [self.pending[i - self.stored][key] for i in range(max(start, self.stored), stop)]
        return _gather(src, self.rows[start:min(stop, self.stored)], extra + ([] if final is None else [final]))

    def value(self, src: Any, key: str, i: int) -> Any:
        """Step ``i``'s value of column ``src`` (the pending window's own for a pending step)."""
        if i >= self.stored:
            return self.pending[i - self.stored][key]
        return _pick(src, int(self.rows[i]))


def _gather(src: Any, rows: np.ndarray, extra: list[Any]) -> Any:
    """``src``'s ``rows`` followed by the ``extra`` values: one copy into a new array (a dict of arrays for a Dict
    space)."""
    if isinstance(src, dict):
        return {k: _gather(v, rows, [e[k] for e in extra]) for k, v in src.items()}
    out = np.empty((len(rows) + len(extra), *src.shape[1:]), dtype=src.dtype)
    np.take(src, rows, axis=0, out=out[:len(rows)])
    for i, value in enumerate(extra, start=len(rows)):
        out[i] = value
    return out


def _pick(x: Any, i: int | None) -> Any:
    """Row ``i`` of an array or a dict of arrays (a tensor as numpy first); ``None``: the value as numpy."""
    if isinstance(x, dict):
        return {k: _pick(v, i) for k, v in x.items()}
    if isinstance(x, torch.Tensor):
        x = _np(x)
    return x if i is None else x[i]


def _one_step_rewards(returns: np.ndarray, used: np.ndarray, gamma: float) -> np.ndarray:
    """Each step's own reward: a row's return minus the discounted rewards of the steps after it that it summed
    (``used`` steps; 1 for a pending step, whose reward is its own)."""
    if (used == 1).all():
        return returns
    rewards = returns.copy()
    for i in range(len(rewards) - 1, -1, -1):
        for k in range(1, int(used[i])):
            if i + k < len(rewards):
                rewards[i] -= gamma ** k * rewards[i + k]
    return rewards


def _ring_rows(buffer: Any) -> np.ndarray:
    """The stored rows, oldest first."""
    size, cap, pos = int(buffer.size), int(buffer.capacity), int(buffer.pos)
    return np.arange(size) if size < cap else np.concatenate([np.arange(pos, cap), np.arange(0, pos)])


def _env_steps(buffer: Any) -> list[_EnvSteps]:
    """Each env's steps (every write is one row per env: the newest row of a vectorized step is the last env's)."""
    n_envs = max(1, int(buffer.num_envs))
    rows = _ring_rows(buffer)
    count = len(rows)
    cols = {"terminated": _np(buffer.terminated), "truncated": _np(buffer.truncated),
            "rewards": _np(buffer.rewards), "used": np.ones(int(buffer.capacity), np.int64)}
    if count:
        cols["used"][rows] = _steps_used(_np(buffer.discounts)[rows], buffer.gamma,
                                          getattr(buffer, "window", buffer.n_step))
    env_of = (np.arange(count) - count) % n_envs
    pending = list(getattr(buffer, "_pending", []))
    out = []
    for env in range(n_envs):
        at = np.flatnonzero(env_of == env)
        out.append(_EnvSteps(rows[at], at, cols, pending, env, float(buffer.gamma)))
    return out


REWARD_SPACE = gym.spaces.Box(-np.inf, np.inf, (), np.float32)
"""The space RLlib's episodes give their rewards column."""


def _column(data: Any, space: dict[str, Any] | None) -> dict[str, Any]:
    return {"data": data, "lookback": 0, "finalized": True, "space": space}


def _episode_state(steps: _EnvSteps, start: int, stop: int, src: dict[str, Any], spaces: dict[str, Any]
                   ) -> dict[str, Any]:
    last = stop - 1
    done = bool(steps.ends[last])
    final = steps.value(src["next_obs"], "next_obs", last) if (done or steps.used[last] == 1) else None
    obs = steps.gather(src["obs"], "obs", start, stop, final)
    n = stop - start
    return {
        "id_": uuid.uuid4().hex, "agent_id": None, "module_id": None, "multi_agent_episode_id": None,
        "observations": _column(obs, spaces["obs"]),
        "actions": _column(steps.gather(src["actions"], "actions", start, stop), spaces["act"]),
        "rewards": _column(steps.rewards[start:stop].astype(np.float32), spaces["reward"]),
        "infos": _column([{} for _ in range(n + (final is not None))], None),
        "extra_model_outputs": None,
        "is_terminated": bool(done and steps.term[last]), "is_truncated": bool(done and not steps.term[last]),
        "t_started": 0, "t": n, "_observation_space": spaces["obs"],
        "_action_space": spaces["act"], "_start_time": None, "_last_step_time": None,
        "custom_data": {},
    }


def _min_tree(tree: Any, n: int) -> np.ndarray:
    """RLlib's min segment over the same leaves (inf where no row is stored), built level by level."""
    size = int(tree.size)
    out = np.full(2 * size, math.inf)
    out[size:size + n] = tree.leaves(n)
    lo = size
    while lo > 1:
        half = lo // 2
        out[half:lo] = np.minimum(out[lo:2 * lo:2], out[lo + 1:2 * lo:2])
        lo = half
    return out


def buffer_state(buffer: Any, obs_space: Any, act_space: Any, steps_added: int, sampled: int) -> dict[str, Any]:
    """RLlib's ``PrioritizedEpisodeReplayBuffer.get_state()`` (``EpisodeReplayBuffer``'s when not prioritized)
    read from rlchain's :class:`~rlchain.algos.core.replay.ReplayBuffer`; see the module docstring. Linear in the
    stored rows; each observation is copied once, into its episode's array (on a CPU buffer)."""
    wrapped = int(buffer.size) >= int(buffer.capacity)
    episodes, indices, tree_to_sample = [], [], {}
    per_env = _env_steps(buffer)
    src = {"obs": _np(buffer.obs), "next_obs": _np(buffer.next_obs), "actions": _np(buffer.actions)}
    spaces = {"obs": gym_space_to_dict(obs_space), "act": gym_space_to_dict(act_space),
              "reward": gym_space_to_dict(REWARD_SPACE)}
    # oldest first: episodes ordered by when their first step was taken, then by env
    order = sorted((int(steps.at[start]), env, start, stop) for env, steps in enumerate(per_env)
                   for start, stop in steps.episodes(wrapped))
    for _, env, start, stop in order:
        steps = per_env[env]
        e_idx = len(episodes)
        stored = steps.rows[start:min(stop, steps.stored)].tolist()
        tree_to_sample.update(zip(stored, range(len(indices), len(indices) + len(stored))))
        indices.extend(zip([e_idx] * len(stored), range(len(stored)), stored))
        episodes.append(_episode_state(steps, start, stop, src, spaces))
    state: dict[str, Any] = {
        "episodes": episodes,
        "episode_id_to_index": [(e["id_"], i) for i, e in enumerate(episodes)],
        "_num_episodes_evicted": 0,
        "_indices": indices,
        "_num_timesteps": sum(e["t"] for e in episodes),
        "_num_timesteps_added": int(steps_added),
        "sampled_timesteps": int(sampled),
    }
    tree = getattr(buffer, "tree", None)
    if tree is not None:
        n = int(buffer.size)
        state.update({
            "_sum_segment": tree.tree.copy(),
            "_min_segment": _min_tree(tree, n),
            "_free_nodes": list(range(n, int(buffer.capacity))),
            "_max_priority": float(buffer.max_priority),
            "_max_idx": max(n - 1, 0),
            "_tree_idx_to_sample_idx": list(tree_to_sample.items()),
            "_last_sampled_indices": [],
        })
    return state


class LocalReplayBuffer:
    """What RLlib's ``algo.local_replay_buffer`` offers a reader: ``get_state()``, ``get_num_timesteps()``,
    ``get_num_episodes()``, ``get_added_timesteps()``, ``get_sampled_timesteps()``, ``len()``. It is rlchain's
    buffer underneath: ``set_state`` is refused (``restore_from_path`` restores it with
    ``store_buffer_in_checkpoints=True``)."""

    def __init__(self, buffer: Any, obs_space: Any, act_space: Any, steps_added: int, sampled: int) -> None:
        self._buffer, self._spaces = buffer, (obs_space, act_space)
        self._added, self._sampled = int(steps_added), int(sampled)

    def get_state(self) -> dict[str, Any]:
        return buffer_state(self._buffer, *self._spaces, self._added, self._sampled)

    def get_num_timesteps(self) -> int:
        return len(self._buffer)

    def get_num_episodes(self) -> int:
        """The episodes :meth:`get_state` would list (counted, not built)."""
        wrapped = int(self._buffer.size) >= int(self._buffer.capacity)
        return sum(len(steps.episodes(wrapped)) for steps in _env_steps(self._buffer))

    def get_added_timesteps(self) -> int:
        return self._added

    def get_sampled_timesteps(self) -> int:
        return self._sampled

    def __len__(self) -> int:
        return len(self._buffer)

    def set_state(self, state: Any) -> None:
        raise NotImplementedError("local_replay_buffer.set_state: the face's buffer is rlchain's; restore it with "
                                  "algo.restore_from_path(path) from a checkpoint saved with "
                                  "store_buffer_in_checkpoints=True")
