"""rl_games' ``rl_games.common.experience``: ``VectorizedReplayBuffer``, the tensor replay buffer rl_games' SAC
fills, for code that builds one itself (a custom off-policy agent, a script that replays stored transitions).

rlchain's SAC keeps its own buffer; this class has rl_games 2.0's interface (its attributes, ``add`` with an
optional ``truncated`` flag, ``sample`` returning six tensors, ``state_dict`` with rl_games' keys) so such code runs
unchanged. The rollout storage of rl_games' PPO agents (``ExperienceBuffer``) and the old numpy buffers
(``ReplayBuffer``, ``PrioritizedReplayBuffer``) are agent code rlchain does not offer: importing one is a one-line
ImportError naming what to use.
"""

from __future__ import annotations

from typing import Any

import torch

NOT_OFFERED = {
    "ExperienceBuffer": "the rollout storage of rl_games' PPO agents; rlchain's PPO keeps its own "
                        "(rlchain.algos.core), and a network or model written for rl_games trains on it as registered",
    "ReplayBuffer": "rl_games' numpy replay buffer; use VectorizedReplayBuffer (this module)",
    "PrioritizedReplayBuffer": "rl_games' numpy prioritized buffer; rlchain's replay has prioritized sampling "
                               "(the config key prioritized_replay, docs/config.md)",
}


def __getattr__(name: str) -> Any:
    if name in NOT_OFFERED:
        raise ImportError(f"rl_games.common.experience.{name} is not offered by rlchain: {NOT_OFFERED[name]}",
                          name="rl_games.common.experience")
    raise AttributeError(f"module 'rl_games.common.experience' has no attribute '{name}'")


class VectorizedReplayBuffer:
    """A ring of ``capacity`` transitions on ``device``, stored in float32 (flags in bool):

    ``obses`` / ``next_obses`` (capacity, *obs_shape), ``actions`` (capacity, *action_shape), ``rewards``,
    ``dones`` and ``truncated`` (capacity, 1). ``idx`` is the next row to write, ``full`` whether every row holds a
    transition."""

    def __init__(self, obs_shape: tuple[int, ...], action_shape: tuple[int, ...], capacity: int,
                 device: str | torch.device) -> None:
        if int(capacity) < 1:
            raise ValueError(f"VectorizedReplayBuffer: capacity must be >= 1, got {capacity}")
        self.device = device
        self.capacity = int(capacity)
        self.obses = torch.zeros((self.capacity, *obs_shape), dtype=torch.float32, device=device)
        self.next_obses = torch.zeros((self.capacity, *obs_shape), dtype=torch.float32, device=device)
        self.actions = torch.zeros((self.capacity, *action_shape), dtype=torch.float32, device=device)
        self.rewards = torch.zeros((self.capacity, 1), dtype=torch.float32, device=device)
        self.dones = torch.zeros((self.capacity, 1), dtype=torch.bool, device=device)
        self.truncated = torch.zeros((self.capacity, 1), dtype=torch.bool, device=device)
        self.idx = 0
        self.full = False

    def _fields(self) -> dict[str, torch.Tensor]:
        return {"obses": self.obses, "actions": self.actions, "rewards": self.rewards, "next_obses": self.next_obses,
                "dones": self.dones, "truncated": self.truncated}

    @torch.no_grad()
    def add(self, obs: torch.Tensor, action: torch.Tensor, reward: torch.Tensor, next_obs: torch.Tensor,
            done: torch.Tensor, truncated: torch.Tensor | None = None) -> None:
        """Write a batch of N transitions (each tensor's first axis) from ``idx`` on, wrapping around; when N is
        larger than the capacity only the newest ``capacity`` rows are kept. ``truncated`` defaults to False."""
        n = int(obs.shape[0])
        if n == 0:
            return
        if truncated is None:
            truncated = torch.zeros_like(done, dtype=torch.bool)
        kept = min(n, self.capacity)
        start = (self.idx + n - kept) % self.capacity  # where the first kept row lands
        rows = (start + torch.arange(kept, device=self.obses.device)) % self.capacity
        for store, value in zip(self._fields().values(), (obs, action, reward, next_obs, done, truncated)):
            store[rows] = value[n - kept:].to(device=store.device, dtype=store.dtype).reshape(kept, *store.shape[1:])
        self.full = self.full or self.idx + n >= self.capacity
        self.idx = (self.idx + n) % self.capacity

    def __len__(self) -> int:
        return self.capacity if self.full else self.idx

    def sample(self, batch_size: int) -> tuple[torch.Tensor, ...]:
        """``batch_size`` rows drawn uniformly (with replacement) among those written (none: a RuntimeError, as in
        rl_games 2.0):
        ``(obses, actions, rewards, next_obses, dones, truncated)``."""
        if len(self) == 0:
            raise RuntimeError("VectorizedReplayBuffer.sample: the buffer is empty (add transitions first)")
        rows = torch.randint(0, len(self), (int(batch_size),), device=self.obses.device)
        return tuple(store[rows] for store in self._fields().values())

    def state_dict(self) -> dict[str, Any]:
        """The buffer for a checkpoint: the tensors on the CPU under rl_games' keys, ``idx`` and ``full``."""
        return {**{key: value.cpu() for key, value in self._fields().items()}, "idx": self.idx, "full": self.full}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`'s output (a state without ``truncated``, from before 2.0, reads as all
        False)."""
        for key, store in self._fields().items():
            if key == "truncated" and key not in state:
                store.zero_()
                continue
            store.copy_(torch.as_tensor(state[key]).to(store.device))
        self.idx, self.full = int(state["idx"]), bool(state["full"])
