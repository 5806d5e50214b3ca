"""Episode returns and lengths across auto-resets, averaged over the last ``games_to_track`` games."""

from __future__ import annotations

from collections import deque

import torch


class EpisodeTracker:
    """Accumulates raw (unshaped) rewards per env and records finished episodes."""

    def __init__(self, num_envs: int, games_to_track: int, device: torch.device) -> None:
        self.returns = torch.zeros(num_envs, dtype=torch.float64, device=device)
        self.lengths = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.finished_returns: deque[float] = deque(maxlen=games_to_track)
        self.finished_lengths: deque[int] = deque(maxlen=games_to_track)
        self.games = 0

    def step(self, rewards: torch.Tensor, dones: torch.Tensor) -> None:
        """rewards (N,) or (N, V) raw; dones (N,) bool. Summed over value heads."""
        if rewards.dim() > 1:
            rewards = rewards.sum(-1)
        self.returns += rewards
        self.lengths += 1
        if dones.any():
            idx = dones.nonzero().squeeze(-1)
            self.finished_returns.extend(self.returns[idx].tolist())
            self.finished_lengths.extend(self.lengths[idx].tolist())
            self.games += int(idx.numel())
            self.returns[idx] = 0.0
            self.lengths[idx] = 0

    def reset_running(self) -> None:
        """Forget episodes in progress (after an env reset)."""
        self.returns.zero_()
        self.lengths.zero_()

    @property
    def has_data(self) -> bool:
        return len(self.finished_returns) > 0

    def mean_return(self) -> float:
        return sum(self.finished_returns) / max(len(self.finished_returns), 1)

    def mean_length(self) -> float:
        return sum(self.finished_lengths) / max(len(self.finished_lengths), 1)

    def state_dict(self) -> dict:
        return {"returns": list(self.finished_returns), "lengths": list(self.finished_lengths),
                "games": self.games}

    def load_state_dict(self, state: dict) -> None:
        self.finished_returns.clear()
        self.finished_lengths.clear()
        self.finished_returns.extend(state["returns"])
        self.finished_lengths.extend(state["lengths"])
        self.games = int(state["games"])
