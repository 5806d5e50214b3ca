"""Replay buffer for off-policy algorithms: preallocated on the device, uniform or prioritized, n-step.

A stored transition is ``(obs, action, reward, next_obs, terminated, truncated)`` where ``next_obs``
is the true next observation (the env's ``final_obs`` where an episode ended) and only
``terminated`` stops bootstrapping: a time-out (``truncated``) still bootstraps from ``next_obs``.

With ``n_step > 1`` the buffer keeps the last n vectorized steps per env and stores
``reward = sum_k gamma^k r_{t+k}`` up to the first step that ended the episode, with
``next_obs``/``terminated`` of that step and ``discount = gamma^(steps used)``. With ``n_step_max`` (RLlib's
``n_step=(lo, hi)`` range) each stored transition sums its own n, drawn uniformly from ``[n_step, n_step_max]``
(the window holds ``n_step_max`` steps); its discount says how many steps it used.

Dict observations kept per key (``obs_shape`` a gymnasium Dict space) are stored per key in each key's
dtype (a uint8 camera image stays uint8 in ``obs`` and ``next_obs``) and sampled back as an
:class:`~rlchain.envs.obs_dict.ObsDict`; flat observations keep one tensor of ``obs_dtype``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.obs_dict import ObsDict, dict_zeros, is_dict_space


class SumTree:
    """A binary sum tree over ``capacity`` leaf priorities (numpy, float64).

    ``find(values)`` maps values in [0, total) to leaves so that leaf i is hit with probability
    ``priority_i / total``; updates and lookups are O(log capacity), vectorized over a batch.
    """

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        size = 2
        while size < capacity:
            size *= 2
        self.size = size
        self.tree = np.zeros(2 * size, dtype=np.float64)

    @property
    def total(self) -> float:
        return float(self.tree[1])

    def leaves(self, n: int | None = None) -> np.ndarray:
        return self.tree[self.size: self.size + (self.capacity if n is None else n)]

    def update(self, indices: np.ndarray, priorities: np.ndarray) -> None:
        indices = np.asarray(indices, dtype=np.int64)
        priorities = np.asarray(priorities, dtype=np.float64)
        # the last write wins for duplicated indices, then parents are recomputed level by level
        nodes = indices + self.size
        self.tree[nodes] = priorities
        while nodes.size and nodes[0] > 1:  # every node sits on the same level
            nodes = np.unique(nodes // 2)
            self.tree[nodes] = self.tree[2 * nodes] + self.tree[2 * nodes + 1]

    def find(self, values: np.ndarray) -> np.ndarray:
        """Leaf index for each value (prefix-sum search)."""
        values = np.asarray(values, dtype=np.float64).copy()
        nodes = np.ones(values.shape, dtype=np.int64)
        while nodes.size and nodes[0] < self.size:  # every node sits on the same level
            left = 2 * nodes
            left_sum = self.tree[left]
            go_right = values >= left_sum
            values = np.where(go_right, values - left_sum, values)
            nodes = np.where(go_right, left + 1, left)
        return np.minimum(nodes - self.size, self.capacity - 1)


class ReplayBuffer:
    """Circular buffer of transitions from ``num_envs`` envs, all tensors on ``device``.

    ``obs_shape``: a shape (``obs`` and ``next_obs`` one tensor each of ``obs_dtype``) or a gymnasium Dict
    space (one buffer per key in the space's dtype, an :class:`ObsDict`; ``obs_dtype`` unused)."""

    def __init__(self, capacity: int, obs_shape: tuple[int, ...] | gym.spaces.Dict, action_shape: tuple[int, ...],
                 device: torch.device | str = "cpu", num_envs: int = 1, obs_dtype: torch.dtype = torch.float32,
                 action_dtype: torch.dtype = torch.float32, n_step: int = 1, gamma: float = 0.99,
                 prioritized: bool = False, alpha: float = 0.6, beta: float = 0.4, eps: float = 1e-6,
                 n_step_max: int | None = None) -> None:
        self.capacity, self.device, self.num_envs = int(capacity), torch.device(device), int(num_envs)
        self.n_step, self.gamma = int(n_step), float(gamma)
        self.n_step_max = None if n_step_max is None or int(n_step_max) <= self.n_step else int(n_step_max)
        self.window = self.n_step if self.n_step_max is None else self.n_step_max  # steps kept before a write
        self.prioritized, self.alpha, self.beta, self.eps = prioritized, float(alpha), float(beta), float(eps)
        c, dev = self.capacity, self.device
        self.per_key = is_dict_space(obs_shape)
        if self.per_key:
            self.obs: torch.Tensor | ObsDict = dict_zeros((c,), obs_shape, dev)
            self.next_obs: torch.Tensor | ObsDict = dict_zeros((c,), obs_shape, dev)
        else:
            self.obs = torch.zeros((c, *obs_shape), dtype=obs_dtype, device=dev)
            self.next_obs = torch.zeros((c, *obs_shape), dtype=obs_dtype, device=dev)
        self.actions = torch.zeros((c, *action_shape), dtype=action_dtype, device=dev)
        self.rewards = torch.zeros(c, dtype=torch.float32, device=dev)
        self.terminated = torch.zeros(c, dtype=torch.bool, device=dev)
        self.truncated = torch.zeros(c, dtype=torch.bool, device=dev)
        self.discounts = torch.zeros(c, dtype=torch.float32, device=dev)
        self.pos = 0
        self.size = 0
        self.tree = SumTree(c) if prioritized else None
        self.max_priority = 1.0
        self._pending: list[dict[str, torch.Tensor]] = []  # the last window-1 steps awaiting their n-step return

    def __len__(self) -> int:
        return self.size

    # ----- writing ------------------------------------------------------------------------
    def add(self, obs: torch.Tensor, actions: torch.Tensor, rewards: torch.Tensor, next_obs: torch.Tensor,
            terminated: torch.Tensor, truncated: torch.Tensor) -> None:
        """One vectorized step: every argument has a leading ``num_envs`` dimension."""
        step = {"obs": obs, "actions": actions, "rewards": rewards.reshape(-1).float(), "next_obs": next_obs,
                "terminated": terminated.reshape(-1).bool(), "truncated": truncated.reshape(-1).bool()}
        step = {k: v.to(self.device) for k, v in step.items()}
        if self.window == 1:
            self._write(step["obs"], step["actions"], step["rewards"], step["next_obs"], step["terminated"],
                        step["truncated"], torch.full_like(step["rewards"], self.gamma))
            return
        self._pending.append(step)
        if len(self._pending) == self.window:
            self._write(*self._nstep(self._pending))
            self._pending.pop(0)

    def add_discounted(self, obs: torch.Tensor, actions: torch.Tensor, rewards: torch.Tensor, next_obs: torch.Tensor,
                       terminated: torch.Tensor, truncated: torch.Tensor, discounts: torch.Tensor) -> None:
        """Transitions whose (n-step) returns the caller summed, each with its own discount (gamma ** its steps):
        any number of them, written as they are (multi-policy DQN / SAC's agents, whose steps are their own)."""
        dev = self.device
        self._write(obs.to(dev), actions.to(dev), rewards.reshape(-1).float().to(dev), next_obs.to(dev),
                    terminated.reshape(-1).bool().to(dev), truncated.reshape(-1).bool().to(dev),
                    discounts.reshape(-1).float().to(dev))

    def _nstep(self, window: list[dict[str, torch.Tensor]]) -> tuple[torch.Tensor, ...]:
        """The n-step transition starting at ``window[0]`` for every env (each env's own n with ``n_step_max``)."""
        first = window[0]
        reward = torch.zeros_like(first["rewards"])
        alive = torch.ones_like(first["terminated"])
        if self.n_step_max is not None:  # an env's steps past its drawn n are left out as if the episode ended
            n = torch.randint(self.n_step, self.n_step_max + 1, alive.shape).to(self.device)
        next_obs = first["next_obs"].clone()
        terminated = first["terminated"].clone()
        truncated = first["truncated"].clone()
        discount = torch.full_like(reward, self.gamma)
        for k, step in enumerate(window):
            if self.n_step_max is not None:
                alive = alive & (n > k)
            reward += alive.float() * (self.gamma ** k) * step["rewards"]
            if k > 0:
                rows = alive
                next_obs[rows] = step["next_obs"][rows]
                terminated[rows] = step["terminated"][rows]
                truncated[rows] = step["truncated"][rows]
                discount[rows] = self.gamma ** (k + 1)
            alive = alive & ~(step["terminated"] | step["truncated"])
        return first["obs"], first["actions"], reward, next_obs, terminated, truncated, discount

    def _write(self, obs: torch.Tensor, actions: torch.Tensor, rewards: torch.Tensor, next_obs: torch.Tensor,
               terminated: torch.Tensor, truncated: torch.Tensor, discounts: torch.Tensor) -> None:
        n = obs.shape[0]
        idx = (torch.arange(n, device=self.device) + self.pos) % self.capacity
        if self.per_key:  # each key's buffer casts on assignment (a uint8 image stays uint8)
            self.obs[idx] = obs
            self.next_obs[idx] = next_obs
        else:
            self.obs[idx] = obs.to(self.obs.dtype)
            self.next_obs[idx] = next_obs.to(self.next_obs.dtype)
        self.actions[idx] = actions.to(self.actions.dtype)
        self.rewards[idx] = rewards
        self.terminated[idx] = terminated
        self.truncated[idx] = truncated
        self.discounts[idx] = discounts
        if self.tree is not None:
            self.tree.update(idx.cpu().numpy(), np.full(n, self.max_priority ** self.alpha))
        self.pos = (self.pos + n) % self.capacity
        self.size = min(self.size + n, self.capacity)

    # ----- reading ------------------------------------------------------------------------
    def sample(self, batch_size: int, beta: float | None = None,
               generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        """A minibatch: obs, actions, rewards, next_obs, terminated, truncated, discounts (gamma^n),
        weights (importance sampling, ones when uniform) and indices (for :meth:`update_priorities`)."""
        if self.size == 0:
            raise RuntimeError("cannot sample from an empty replay buffer")
        if self.tree is None:
            idx = torch.randint(0, self.size, (batch_size,), device=self.device, generator=generator)
            weights = torch.ones(batch_size, device=self.device)
        else:
            idx_np, weights_np = self._sample_prioritized(batch_size, self.beta if beta is None else beta, generator)
            idx = torch.as_tensor(idx_np, device=self.device)
            weights = torch.as_tensor(weights_np, dtype=torch.float32, device=self.device)
        return {"obs": self.obs[idx], "actions": self.actions[idx], "rewards": self.rewards[idx],
                "next_obs": self.next_obs[idx], "terminated": self.terminated[idx],
                "truncated": self.truncated[idx], "discounts": self.discounts[idx], "weights": weights,
                "indices": idx}

    def _sample_prioritized(self, batch_size: int, beta: float,
                            generator: torch.Generator | None) -> tuple[np.ndarray, np.ndarray]:
        """Stratified proportional sampling: one uniform draw in each of ``batch_size`` equal segments."""
        total = self.tree.total
        u = torch.rand(batch_size, generator=generator, dtype=torch.float64).numpy()
        values = (np.arange(batch_size) + u) * (total / batch_size)
        idx = self.tree.find(np.minimum(values, np.nextafter(total, 0)))
        idx = np.minimum(idx, self.size - 1)
        leaves = self.tree.leaves(self.size)
        probs = leaves[idx] / total
        min_prob = leaves[leaves > 0].min() / total
        weights = (self.size * probs) ** (-beta) / (self.size * min_prob) ** (-beta)
        return idx, weights

    def update_priorities(self, indices: torch.Tensor, td_errors: torch.Tensor) -> None:
        """New priorities ``(|td| + eps)`` for the sampled ``indices`` (stored as priority^alpha)."""
        if self.tree is None:
            return
        priorities = td_errors.detach().abs().double().cpu().numpy() + self.eps
        self.max_priority = max(self.max_priority, float(priorities.max()))
        self.tree.update(indices.cpu().numpy(), priorities ** self.alpha)

    # ----- checkpoints --------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """Plain tensors and dicts of tensors on the CPU (a checkpoint loads them with weights_only)."""
        n = self.size
        state = {"pos": self.pos, "size": n, "max_priority": self.max_priority, "capacity": self.capacity,
                 "pending": [{k: _to_cpu(v) for k, v in s.items()} for s in self._pending]}
        for name in ("obs", "next_obs", "actions", "rewards", "terminated", "truncated", "discounts"):
            state[name] = _to_cpu(getattr(self, name)[:n])
        if self.tree is not None:
            state["priorities"] = self.tree.leaves(n).copy()
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if int(state["capacity"]) != self.capacity:
            raise ValueError(f"replay buffer capacity {state['capacity']} in the checkpoint, {self.capacity} now")
        n = int(state["size"])
        for name in ("obs", "next_obs", "actions", "rewards", "terminated", "truncated", "discounts"):
            getattr(self, name)[:n] = _to_device(state[name], self.device)
        self.pos, self.size, self.max_priority = int(state["pos"]), n, float(state["max_priority"])
        self._pending = [{k: _to_device(v, self.device) for k, v in s.items()} for s in state["pending"]]
        if self.tree is not None:
            self.tree.tree[:] = 0
            if "priorities" in state:
                self.tree.update(np.arange(n), state["priorities"])
            else:
                self.tree.update(np.arange(n), np.full(n, self.max_priority ** self.alpha))


def _to_cpu(x: torch.Tensor | ObsDict) -> torch.Tensor | dict[str, torch.Tensor]:
    """A tensor on the CPU; an ObsDict as a plain dict of CPU tensors (what weights_only loads)."""
    return {k: v.cpu() for k, v in x.items()} if isinstance(x, dict) else x.cpu()


def _to_device(x: torch.Tensor | dict[str, torch.Tensor], device: torch.device) -> torch.Tensor | ObsDict:
    """The inverse of :func:`_to_cpu`: a dict of tensors comes back as an ObsDict."""
    return ObsDict({k: v.to(device) for k, v in x.items()}) if isinstance(x, dict) else x.to(device)
