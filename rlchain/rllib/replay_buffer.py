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
    """A tensor (or a dict of tensors) as numpy on the CPU."""
    if isinstance(x, dict):
        return {k: _np(v) for k, v in x.items()}
    return x.detach().cpu().numpy()


def _take(x: Any, idx: Any) -> Any:
    if isinstance(x, dict):
        return {k: _take(v, idx) for k, v in x.items()}
    return x[idx]


def _stack(items: list[Any]) -> Any:
    if items and isinstance(items[0], dict):
        return {k: np.stack([it[k] for it in items]) for k in items[0]}
    return np.stack(items)


def _steps_used(discounts: np.ndarray, gamma: float, n_step: int) -> np.ndarray:
    """How many env steps each row's return sums (its discount is gamma ** steps)."""
    if n_step == 1:
        return np.ones(len(discounts), dtype=np.int64)
    if not 0.0 < gamma < 1.0:
        raise ValueError(f"local_replay_buffer.get_state(): with n_step {n_step} and gamma {gamma} the face cannot "
                         f"take its n-step rows apart into steps (gamma must be in (0, 1))")
    steps = np.rint(np.log(np.maximum(discounts.astype(np.float64), 1e-300)) / math.log(gamma)).astype(np.int64)
    return np.clip(steps, 1, n_step)


def _env_steps(buffer: Any) -> list[list[dict[str, Any]]]:
    """Each env's steps in the order taken: the stored rows (oldest first), then the pending window's steps."""
    n_envs = max(1, int(buffer.num_envs))
    size, cap, pos = int(buffer.size), int(buffer.capacity), int(buffer.pos)
    rows = np.arange(size) if size < cap else np.concatenate([np.arange(pos, cap), np.arange(0, pos)])
    steps: list[list[dict[str, Any]]] = [[] for _ in range(n_envs)]
    if size:
        idx = torch.as_tensor(rows, device=buffer.device)
        obs, next_obs = _np(_take(buffer.obs, idx)), _np(_take(buffer.next_obs, idx))
        actions, rewards = _np(buffer.actions[idx]), _np(buffer.rewards[idx])
        term, trunc = _np(buffer.terminated[idx]), _np(buffer.truncated[idx])
        used = _steps_used(_np(buffer.discounts[idx]), buffer.gamma, buffer.n_step)
        count = len(rows)
        for j, row in enumerate(rows):
            env = (j - count) % n_envs  # every write is one row per env: the newest row is the last env's
            steps[env].append({"obs": _take(obs, j), "next_obs": _take(next_obs, j), "action": actions[j],
                               "ret": float(rewards[j]), "used": int(used[j]), "term": bool(term[j]),
                               "trunc": bool(trunc[j]), "row": int(row), "at": j})
    for at, step in enumerate(getattr(buffer, "_pending", []), start=len(rows)):
        s = {k: _np(v) for k, v in step.items()}
        for env in range(n_envs):
            steps[env].append({"obs": _take(s["obs"], env), "next_obs": _take(s["next_obs"], env),
                               "action": s["actions"][env], "reward": float(s["rewards"][env]), "used": 1,
                               "term": bool(s["terminated"][env]), "trunc": bool(s["truncated"][env]), "row": None,
                               "at": at})
    return steps


def _one_step_rewards(steps: list[dict[str, Any]], gamma: float) -> None:
    """Each step's own reward: a pending step's is stored; a row's return minus the discounted rewards after it."""
    for i in range(len(steps) - 1, -1, -1):
        step = steps[i]
        if "reward" in step:
            continue
        later = sum(gamma ** k * steps[i + k]["reward"] for k in range(1, step["used"]) if i + k < len(steps))
        step["reward"] = step["ret"] - later


def _ends(step: dict[str, Any]) -> bool:
    return step["used"] == 1 and (step["term"] or step["trunc"])


def _episodes(steps: list[dict[str, Any]], wrapped: bool) -> list[list[dict[str, Any]]]:
    """One env's steps cut into episodes; a first episode whose start the ring overwrote is left out."""
    out, current = [], []
    for step in steps:
        current.append(step)
        if _ends(step):
            out.append(current)
            current = []
    if current:
        out.append(current)
    if wrapped and len(out) > 1 and out[0][0]["row"] is not None:
        out = out[1:]
    return out


REWARD_SPACE = gym.spaces.Box(-np.inf, np.inf, (), np.float32)
"""The space RLlib's episodes give their rewards column."""


def _column(data: Any, space: gym.spaces.Space | None) -> dict[str, Any]:
    return {"data": data, "lookback": 0, "finalized": True, "space": gym_space_to_dict(space)}


def _episode_state(steps: list[dict[str, Any]], obs_space: Any, act_space: Any) -> dict[str, Any]:
    last = steps[-1]
    done = _ends(last)
    final = last["next_obs"] if (done or last["used"] == 1) else None
    obs = [s["obs"] for s in steps] + ([final] if final is not None else [])
    n = len(steps)
    return {
        "id_": uuid.uuid4().hex, "agent_id": None, "module_id": None, "multi_agent_episode_id": None,
        "observations": _column(_stack(obs), obs_space),
        "actions": _column(np.stack([s["action"] for s in steps]), act_space),
        "rewards": _column(np.asarray([s["reward"] for s in steps], dtype=np.float32), REWARD_SPACE),
        "infos": _column([{} for _ in range(len(obs))], None),
        "extra_model_outputs": None,
        "is_terminated": bool(done and last["term"]), "is_truncated": bool(done and not last["term"]),
        "t_started": 0, "t": n, "_observation_space": gym_space_to_dict(obs_space),
        "_action_space": gym_space_to_dict(act_space), "_start_time": None, "_last_step_time": None,
        "custom_data": {},
    }


def _min_tree(tree: Any, n: int) -> np.ndarray:
    """RLlib's min segment over the same leaves (inf where no row is stored)."""
    size = int(tree.size)
    out = np.full(2 * size, math.inf)
    out[size:size + n] = tree.leaves(n)
    for node in range(size - 1, 0, -1):
        out[node] = min(out[2 * node], out[2 * node + 1])
    return out


def buffer_state(buffer: Any, obs_space: Any, act_space: Any, steps_added: int, sampled: int) -> dict[str, Any]:
    """RLlib's ``PrioritizedEpisodeReplayBuffer.get_state()`` (``EpisodeReplayBuffer``'s when not prioritized)
    read from rlchain's :class:`~rlchain.algos.core.replay.ReplayBuffer`; see the module docstring."""
    wrapped = int(buffer.size) >= int(buffer.capacity)
    episodes, indices, tree_to_sample = [], [], {}
    per_env = _env_steps(buffer)
    cut = [_episodes(s, wrapped) for s in per_env]
    for env_steps in per_env:
        _one_step_rewards(env_steps, float(buffer.gamma))
    # oldest first: episodes ordered by when their first step was taken, then by env
    order = sorted((eps[0]["at"], env, k) for env, eps_list in enumerate(cut) for k, eps in enumerate(eps_list))
    for _, env, k in order:
        eps = cut[env][k]
        e_idx = len(episodes)
        for t, step in enumerate(eps):
            if step["row"] is not None:
                tree_to_sample[step["row"]] = len(indices)
                indices.append((e_idx, t, step["row"]))
        episodes.append(_episode_state(eps, obs_space, act_space))
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
        return len(self.get_state()["episodes"])

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
