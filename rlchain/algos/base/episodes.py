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

    def __init__(self, num_envs: int, games_to_track: int, device: torch.device,
                 success_mode: str = "any") -> None:
        self.returns = torch.zeros(num_envs, dtype=torch.float64, device=device)
        self.lengths = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.finished_returns: deque[float] = deque(maxlen=games_to_track)
        self.finished_lengths: deque[int] = deque(maxlen=games_to_track)
        self.games = 0
        # task success of the episodes in progress: reported at some step, succeeded at any / the last one
        self.success_mode = success_mode
        self.success_seen = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self.success_any = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self.success_last = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self.finished_successes: deque[float] = deque(maxlen=games_to_track)

    def step(self, rewards: torch.Tensor, dones: torch.Tensor, dropped: Any = None,
             rows: slice = slice(None), success: Any = None) -> None:
        """rewards (n,) or (n, V) raw; dones (n,) bool, for the envs ``rows`` (all N by default; a
        pipelined rollout steps one env group at a time). Summed over value heads.

        ``dropped`` (n,) bool (optional, ``vecenv.dropped_rows``): episodes cut by the backend (a dead
        Ray worker) are forgotten, not recorded as finished games. ``success`` (n,) float (optional,
        ``envs.success.step_success``): the env's success value this step, NaN where it gave none.
        """
        if rewards.dim() > 1:
            rewards = rewards.sum(-1)
        returns, lengths = self.returns[rows], self.lengths[rows]  # views: updated in place
        lost = None if dropped is None else torch.as_tensor(dropped, device=dones.device).bool().reshape(-1)
        if lost is not None:
            dones = dones & ~lost
        returns += rewards
        lengths += 1
        if success is not None:
            self._step_success(torch.as_tensor(success, device=dones.device).reshape(-1), rows)
        if dones.any():
            idx = dones.nonzero().squeeze(-1)
            self.finished_returns.extend(returns[idx].tolist())
            self.finished_lengths.extend(lengths[idx].tolist())
            self.games += int(idx.numel())
            returns[idx] = 0.0
            lengths[idx] = 0
            self._finish_success(idx, rows)
        if lost is not None:
            returns[lost] = 0.0
            lengths[lost] = 0
            self._forget_success(lost, rows)

    def _step_success(self, success: torch.Tensor, rows: slice) -> None:
        """Fold one step's success values (n,) float, NaN = none, into the episodes in progress."""
        seen = ~torch.isnan(success)
        hit = seen & (success > 0.5)
        self.success_seen[rows] |= seen
        self.success_any[rows] |= hit
        last = self.success_last[rows]  # a view
        last[seen] = hit[seen]

    def _finish_success(self, idx: torch.Tensor, rows: slice) -> None:
        """Record the success of the episodes that just ended (rows ``idx`` of ``rows``) and clear them."""
        seen, hit_any, hit_last = self.success_seen[rows], self.success_any[rows], self.success_last[rows]
        hit = hit_any if self.success_mode == "any" else hit_last
        reported = idx[seen[idx]]
        if reported.numel():
            self.finished_successes.extend(hit[reported].float().tolist())
        self._forget_success(idx, rows)

    def _forget_success(self, idx: torch.Tensor, rows: slice) -> None:
        for flags in (self.success_seen, self.success_any, self.success_last):
            flags[rows][idx] = False

    def record(self, returns: list[float], lengths: list[int],
               successes: list[tuple[bool, bool] | None] | None = None) -> None:
        """Games finished elsewhere (an asynchronous runner tracked them): add them as they are.
        ``successes``: per game None (no success reported) or (succeeded at any step, at the last)."""
        self.finished_returns.extend(returns)
        self.finished_lengths.extend(lengths)
        self.games += len(returns)
        pick = 0 if self.success_mode == "any" else 1
        self.finished_successes.extend(float(s[pick]) for s in successes or () if s is not None)

    def reset_running(self) -> None:
        """Forget episodes in progress (after an env reset)."""
        self.returns.zero_()
        self.lengths.zero_()
        for flags in (self.success_seen, self.success_any, self.success_last):
            flags.zero_()

    @property
    def has_data(self) -> bool:
        return len(self.finished_returns) > 0

    def mean_return(self) -> float:
        return sum(self.finished_returns) / max(len(self.finished_returns), 1)

    def mean_length(self) -> float:
        return sum(self.finished_lengths) / max(len(self.finished_lengths), 1)

    @property
    def has_success(self) -> bool:
        """Whether any tracked finished episode had a success value from the env."""
        return len(self.finished_successes) > 0

    def success_rate(self) -> float:
        """Fraction of the tracked episodes with a success value that succeeded."""
        return sum(self.finished_successes) / max(len(self.finished_successes), 1)

    def running_state(self) -> dict[str, torch.Tensor]:
        """The episodes in progress (returns, lengths, success flags so far), copied: with the envs'
        own state they let a resumed run finish those episodes exactly as an uninterrupted one."""
        return {name: getattr(self, name).clone() for name in self.RUNNING}

    def load_running_state(self, state: dict[str, torch.Tensor]) -> None:
        """Put back :meth:`running_state` (on this tracker's device)."""
        for name in self.RUNNING:
            getattr(self, name).copy_(state[name].to(getattr(self, name).device))

    RUNNING = ("returns", "lengths", "success_seen", "success_any", "success_last")

    def state_dict(self) -> dict:
        """The finished games (the last ``games_to_track``) and the games count."""
        return {"returns": list(self.finished_returns), "lengths": list(self.finished_lengths),
                "games": self.games, "successes": list(self.finished_successes)}

    def load_state_dict(self, state: dict) -> None:
        """Put back :meth:`state_dict` (episodes in progress are not part of it: :meth:`load_running_state`)."""
        self.finished_returns.clear()
        self.finished_lengths.clear()
        self.finished_returns.extend(state["returns"])
        self.finished_lengths.extend(state["lengths"])
        self.games = int(state["games"])
        self.finished_successes.clear()
        self.finished_successes.extend(state.get("successes", []))  # absent in older checkpoints
