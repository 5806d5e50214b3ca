"""Episode returns and lengths across auto-resets, averaged over the last ``games_to_track`` games.

What counts as one game: normally an episode (``terminated | truncated``) and its raw reward. An
env that reports ``StepResult.game_reward`` / ``game_over`` (Atari with episodic life or clipped
rewards) is counted by whole games and their unclipped score instead: :func:`game_outcome`.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import torch


def game_outcome(result: Any, rewards: torch.Tensor, dones: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(game rewards (N,), game ends (N,) bool) of a StepResult, on the device of ``rewards``.

    ``rewards`` / ``dones`` are the training reward and episode end of the step; they are returned
    unchanged unless the env sets ``result.game_reward`` / ``result.game_over``.
    """
    if getattr(result, "game_reward", None) is not None:
        rewards = torch.as_tensor(result.game_reward, device=rewards.device).to(rewards.dtype).reshape(-1)
    if getattr(result, "game_over", None) is not None:
        dones = torch.as_tensor(result.game_over, device=dones.device).bool().reshape(-1)
    return rewards, dones


class EpisodeTracker:
    """Accumulates raw (unshaped) rewards per env and records finished episodes."""

    def __init__(self, num_envs: int, games_to_track: int, device: torch.device) -> None:
        self.returns = torch.zeros(num_envs, dtype=torch.float64, device=device)
        self.lengths = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.finished_returns: deque[float] = deque(maxlen=games_to_track)
        self.finished_lengths: deque[int] = deque(maxlen=games_to_track)
        self.games = 0

    def step(self, rewards: torch.Tensor, dones: torch.Tensor, dropped: Any = None,
             rows: slice = slice(None)) -> None:
        """rewards (n,) or (n, V) raw; dones (n,) bool, for the envs ``rows`` (all N by default; a
        pipelined rollout steps one env group at a time). Summed over value heads.

        ``dropped`` (n,) bool (optional, ``vecenv.dropped_rows``): episodes cut by the backend (a dead
        Ray worker) are forgotten, not recorded as finished games.
        """
        if rewards.dim() > 1:
            rewards = rewards.sum(-1)
        returns, lengths = self.returns[rows], self.lengths[rows]  # views: updated in place
        lost = None if dropped is None else torch.as_tensor(dropped, device=dones.device).bool().reshape(-1)
        if lost is not None:
            dones = dones & ~lost
        returns += rewards
        lengths += 1
        if dones.any():
            idx = dones.nonzero().squeeze(-1)
            self.finished_returns.extend(returns[idx].tolist())
            self.finished_lengths.extend(lengths[idx].tolist())
            self.games += int(idx.numel())
            returns[idx] = 0.0
            lengths[idx] = 0
        if lost is not None:
            returns[lost] = 0.0
            lengths[lost] = 0

    def record(self, returns: list[float], lengths: list[int]) -> None:
        """Games finished elsewhere (an asynchronous runner tracked them): add them as they are."""
        self.finished_returns.extend(returns)
        self.finished_lengths.extend(lengths)
        self.games += len(returns)

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
