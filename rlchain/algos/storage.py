"""Preallocated on-device rollout storage and its flat minibatch iterator."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import torch


@dataclass
class Batch:
    """One minibatch, flat over (time, env): every tensor has leading dim B."""

    obs: torch.Tensor
    actions: torch.Tensor
    log_probs: torch.Tensor
    values: torch.Tensor
    returns: torch.Tensor
    advantages: torch.Tensor
    params: torch.Tensor


class RolloutStorage:
    """Fixed-size (T, N) buffers allocated once on the training device.

    ``add(t, ...)`` writes step t; writing past the horizon or reading an unfilled rollout raises.
    """

    def __init__(self, horizon: int, num_envs: int, obs_shape: tuple[int, ...], obs_dtype: torch.dtype,
                 action_shape: tuple[int, ...], action_dtype: torch.dtype, param_size: int,
                 value_size: int, device: torch.device) -> None:
        t, n = horizon, num_envs
        self.horizon, self.num_envs = horizon, num_envs
        kw = {"device": device}
        self.obs = torch.zeros((t, n, *obs_shape), dtype=obs_dtype, **kw)
        self.actions = torch.zeros((t, n, *action_shape), dtype=action_dtype, **kw)
        self.log_probs = torch.zeros((t, n), **kw)
        self.values = torch.zeros((t, n, value_size), **kw)
        self.final_values = torch.zeros((t, n, value_size), **kw)
        self.params = torch.zeros((t, n, param_size), **kw)
        self.rewards = torch.zeros((t, n, value_size), **kw)
        self.terminated = torch.zeros((t, n), dtype=torch.bool, **kw)
        self.dones = torch.zeros((t, n), dtype=torch.bool, **kw)
        self.advantages = torch.zeros((t, n, value_size), **kw)
        self.returns = torch.zeros((t, n, value_size), **kw)
        self.filled = 0

    def add(self, t: int, obs: torch.Tensor, actions: torch.Tensor, log_probs: torch.Tensor,
            values: torch.Tensor, params: torch.Tensor) -> None:
        """Record what the policy saw and did at step t (rewards/dones come with :meth:`add_outcome`)."""
        if not 0 <= t < self.horizon:
            raise IndexError(f"step {t} outside horizon {self.horizon}")
        self.obs[t] = obs
        self.actions[t] = actions
        self.log_probs[t] = log_probs
        self.values[t] = values
        self.params[t] = params
        self.filled = t + 1

    def add_outcome(self, t: int, rewards: torch.Tensor, terminated: torch.Tensor,
                    dones: torch.Tensor) -> None:
        """Record the env's answer to step t: shaped rewards (N, V) and done flags (N,)."""
        self.rewards[t] = rewards
        self.terminated[t] = terminated
        self.dones[t] = dones

    def minibatches(self, minibatch_size: int, advantages: torch.Tensor) -> Iterator[Batch]:
        """Shuffle the whole rollout and yield flat minibatches; ``advantages`` is (T, N) or (T*N,)."""
        if self.filled != self.horizon:
            raise RuntimeError(f"rollout holds {self.filled} of {self.horizon} steps")
        size = self.horizon * self.num_envs
        flat = {
            "obs": self.obs.reshape(size, *self.obs.shape[2:]),
            "actions": self.actions.reshape(size, *self.actions.shape[2:]),
            "log_probs": self.log_probs.reshape(size),
            "values": self.values.reshape(size, -1),
            "returns": self.returns.reshape(size, -1),
            "advantages": advantages.reshape(size),
            "params": self.params.reshape(size, -1),
        }
        order = torch.randperm(size, device=self.obs.device)
        for start in range(0, size, minibatch_size):
            idx = order[start:start + minibatch_size]
            yield Batch(**{k: v.index_select(0, idx) for k, v in flat.items()})
