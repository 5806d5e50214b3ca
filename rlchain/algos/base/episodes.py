"""Episode returns and lengths across auto-resets, averaged over the last ``games_to_track`` games.

What counts as one game: normally an episode (``terminated | truncated``) and its raw reward. An
env that reports ``StepResult.game_reward`` / ``game_over`` (Atari with episodic life or clipped
rewards) is counted by whole games and their unclipped score instead:
:func:`rlchain.envs.vecenv.game_outcome`.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
import torch

_EVERY = slice(None)
"""Every env's rows (the default ``rows``): the buffers themselves, no indexing."""


class EpisodeTracker:
    """Accumulates raw (unshaped) rewards per env and records finished episodes."""

    def __init__(self, num_envs: int, games_to_track: int, device: torch.device,
                 success_mode: str = "any") -> None:
        self.returns = torch.zeros(num_envs, dtype=torch.float64, device=device)
        self.lengths = torch.zeros(num_envs, dtype=torch.long, device=device)
        self._finished_returns: deque[float] = deque(maxlen=games_to_track)
        self._finished_lengths: deque[int] = deque(maxlen=games_to_track)
        self._games = 0
        # episodes that ended since the last read, as device tensors: no host sync per step (on a GPU a
        # sync per step cost more than the step's work); read into the deques in step order on demand
        self._pending: list[tuple[torch.Tensor | None, ...]] = []
        self._tracks_success = False  # True from the first step that reported a success value
        self._cheap_sync = torch.device(device).type == "cpu"
        # task success of the episodes in progress: reported at some step, succeeded at any / the last one
        self.success_mode = success_mode
        self.success_seen = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self.success_any = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self.success_last = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self._finished_successes: deque[float] = deque(maxlen=games_to_track)
        self._views_of: tuple[torch.Tensor, torch.Tensor] | None = None  # the tensors _views are of
        self._views: tuple[np.ndarray, np.ndarray] = ()

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
        if isinstance(rows, slice) and rows == _EVERY:  # the buffers themselves (indexing costs a small rollout's step)
            returns, lengths = self.returns, self.lengths
        else:
            returns, lengths = self.returns[rows], self.lengths[rows]  # views: updated in place
        lost = None if dropped is None else torch.as_tensor(dropped, device=dones.device).bool().reshape(-1)
        if lost is not None:
            dones = dones & ~lost
        returns += rewards
        lengths += 1
        if success is not None:
            self._step_success(torch.as_tensor(success, device=dones.device).reshape(-1), rows)
            self._tracks_success = True
        ended = dones if lost is None else dones | lost
        if self._cheap_sync and not bool(ended.any()):  # on a CPU the check costs less than the copies
            return
        if self._tracks_success:  # (before any success value every flag is False: nothing to keep)
            seen, hit = self.success_seen[rows], self._success_flags()[rows]
            self._pending.append((dones.clone(), returns.clone(), lengths.clone(), seen & dones, hit & dones))
            for flags in (self.success_seen, self.success_any, self.success_last):
                flags[rows] &= ~ended
        else:
            self._pending.append((dones.clone(), returns.clone(), lengths.clone(), None, None))
        returns.masked_fill_(ended, 0.0)
        lengths.masked_fill_(ended, 0)
        if len(self._pending) >= self.MAX_PENDING:
            self._flush()

    @property
    def on_host(self) -> bool:
        """Whether the statistics live in CPU memory (:meth:`host_step` may update them in numpy)."""
        return self._cheap_sync

    def host_step(self, rewards: np.ndarray, dones: np.ndarray, dropped: Any = None, rows: slice = _EVERY,
                  success: Any = None) -> None:
        """:meth:`step` of a CPU tracker with the step's (n,) float32 rewards and (n,) bool dones as numpy
        arrays: the same sums (float64 += float32, exact in both) made in numpy on the tensors' own memory,
        a fraction of the cost of torch's per-op dispatch on a few envs. A step with a success value, or
        once success is tracked, goes through :meth:`step`."""
        if success is not None or self._tracks_success:
            self.step(torch.from_numpy(rewards), torch.from_numpy(dones), dropped=dropped, rows=rows,
                      success=success)
            return
        returns, lengths = self._host_views()
        if rows != _EVERY:
            returns, lengths = returns[rows], lengths[rows]  # views: updated in place
        lost = None if dropped is None else np.asarray(dropped).astype(bool).reshape(-1)
        if lost is not None:
            dones = dones & ~lost
        returns += rewards
        lengths += 1
        ended = dones if lost is None else dones | lost
        if not ended.any():
            return
        self._pending.append((torch.from_numpy(dones.copy()), torch.from_numpy(returns.copy()),
                              torch.from_numpy(lengths.copy()), None, None))
        returns[ended] = 0.0
        lengths[ended] = 0
        if len(self._pending) >= self.MAX_PENDING:
            self._flush()

    def _host_views(self) -> tuple[np.ndarray, np.ndarray]:
        """numpy views of :attr:`returns` and :attr:`lengths` (made again if either tensor was replaced)."""
        seen = self._views_of
        if seen is None or seen[0] is not self.returns or seen[1] is not self.lengths:
            self._views_of = (self.returns, self.lengths)
            self._views = (self.returns.numpy(), self.lengths.numpy())
        return self._views

    MAX_PENDING = 64
    """Steps of ended episodes kept on the device before they are read anyway."""

    def _success_flags(self) -> torch.Tensor:
        return self.success_any if self.success_mode == "any" else self.success_last

    def _flush(self) -> None:
        """Move the episodes that ended since the last read into the deques, in the order they ended
        (step by step, env by env): one host sync for all of them."""
        if not self._pending:
            return
        pending, self._pending = self._pending, []
        dones, returns, lengths = (torch.cat([entry[k] for entry in pending]) for k in range(3))
        idx = dones.nonzero().squeeze(-1)
        self._finished_returns.extend(returns[idx].tolist())
        self._finished_lengths.extend(lengths[idx].tolist())
        self._games += int(idx.numel())
        with_success = [entry for entry in pending if entry[3] is not None]
        if with_success:
            seen, hit = torch.cat([entry[3] for entry in with_success]), torch.cat([e[4] for e in with_success])
            self._finished_successes.extend(hit[seen].float().tolist())

    @property
    def finished_returns(self) -> deque[float]:
        """The raw returns of the last ``games_to_track`` finished games, oldest first."""
        self._flush()
        return self._finished_returns

    @property
    def finished_lengths(self) -> deque[int]:
        self._flush()
        return self._finished_lengths

    @property
    def finished_successes(self) -> deque[float]:
        """1.0 / 0.0 per tracked finished game that reported a success value."""
        self._flush()
        return self._finished_successes

    @property
    def games(self) -> int:
        """Games finished since the start of the run."""
        self._flush()
        return self._games

    @games.setter
    def games(self, value: int) -> None:
        self._flush()
        self._games = int(value)

    def _step_success(self, success: torch.Tensor, rows: slice) -> None:
        """Fold one step's success values (n,) float, NaN = none, into the episodes in progress."""
        seen = ~torch.isnan(success)
        hit = seen & (success > 0.5)
        self.success_seen[rows] |= seen
        self.success_any[rows] |= hit
        last = self.success_last[rows]  # a view
        last.copy_(torch.where(seen, hit, last))

    def record(self, returns: list[float], lengths: list[int],
               successes: list[tuple[bool, bool] | None] | None = None) -> None:
        """Games finished elsewhere (an asynchronous runner tracked them): add them as they are.
        ``successes``: per game None (no success reported) or (succeeded at any step, at the last)."""
        self._flush()
        self._finished_returns.extend(returns)
        self._finished_lengths.extend(lengths)
        self._games += len(returns)
        pick = 0 if self.success_mode == "any" else 1
        self._finished_successes.extend(float(s[pick]) for s in successes or () if s is not None)

    def reset_running(self) -> None:
        """Forget episodes in progress (after an env reset)."""
        self._flush()
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
        self._tracks_success = self._tracks_success or bool(self.success_seen.any())

    RUNNING = ("returns", "lengths", "success_seen", "success_any", "success_last")

    def state_dict(self) -> dict:
        """The finished games (the last ``games_to_track``) and the games count."""
        return {"returns": list(self.finished_returns), "lengths": list(self.finished_lengths),
                "games": self.games, "successes": list(self.finished_successes)}

    def load_state_dict(self, state: dict) -> None:
        """Put back :meth:`state_dict` (episodes in progress are not part of it: :meth:`load_running_state`)."""
        self._pending.clear()
        self._finished_returns.clear()
        self._finished_lengths.clear()
        self._finished_returns.extend(state["returns"])
        self._finished_lengths.extend(state["lengths"])
        self._games = int(state["games"])
        self._finished_successes.clear()
        self._finished_successes.extend(state.get("successes", []))  # absent in older checkpoints


class AgentEpisodes(EpisodeTracker):
    """Episode returns per agent row; an episode's length counts the agent's own (active) steps."""

    def agent_step(self, rewards: torch.Tensor, dones: torch.Tensor, active: torch.Tensor) -> None:
        """rewards (R,), dones (R,) bool (the agent ended at this step), active (R,) bool (it acted)."""
        self.returns += rewards
        self.lengths += active.long()
        if dones.any():
            idx = dones.nonzero().squeeze(-1)
            self.finished_returns.extend(self.returns[idx].tolist())
            self.finished_lengths.extend(self.lengths[idx].tolist())
            self.games += int(idx.numel())
            self.returns[idx] = 0.0
            self.lengths[idx] = 0
