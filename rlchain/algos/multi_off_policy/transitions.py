"""Replay transitions of agents that are not always there: from an agent's step to its next active step.

A row (one agent of one env) is *active* at a step when the agent acts there. Its transition starts at an active
step and ends at the row's next active step (its observation is the transition's ``next_obs``) or at the agent's
own end (``next_obs`` its final observation, ``terminated`` / ``truncated`` its own). The rewards the agent gets
in between -- while it waits for its turn, or on the steps after its last move -- are summed into the transition,
as :func:`rlchain.algos.multi_policy.masked.masked_gae` sums them on the PPO side. Rows without an open
transition (absent agents, agents that already ended) add nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class Transitions:
    """Finished transitions, one per row that finished one (all tensors share the leading dimension)."""

    obs: torch.Tensor
    actions: torch.Tensor
    rewards: torch.Tensor
    next_obs: torch.Tensor
    terminated: torch.Tensor
    truncated: torch.Tensor
    rows: torch.Tensor
    """(K,) the row of each transition."""

    def __len__(self) -> int:
        return int(self.obs.shape[0])


class OpenTransitions:
    """Each row's open transition: the observation and action of its last active step, the rewards since."""

    def __init__(self, rows: int, obs_shape: tuple[int, ...], action_shape: tuple[int, ...],
                 action_dtype: torch.dtype, device: torch.device) -> None:
        self.open = torch.zeros(rows, dtype=torch.bool, device=device)
        self.obs = torch.zeros((rows, *obs_shape), dtype=torch.float32, device=device)
        self.actions = torch.zeros((rows, *action_shape), dtype=action_dtype, device=device)
        self.rewards = torch.zeros(rows, dtype=torch.float32, device=device)

    def act(self, obs: torch.Tensor, actions: torch.Tensor, active: torch.Tensor) -> Transitions:
        """The active rows act with ``actions`` from ``obs``: their open transitions end at ``obs`` (returned),
        new ones open."""
        rows = self.open & active
        done = Transitions(self.obs[rows], self.actions[rows], self.rewards[rows], obs[rows],
                           torch.zeros_like(self.rewards[rows], dtype=torch.bool),
                           torch.zeros_like(self.rewards[rows], dtype=torch.bool), rows.nonzero().squeeze(-1))
        self.obs[active] = obs[active].float()
        self.actions[active] = actions[active].to(self.actions.dtype)
        self.rewards[active] = 0.0
        self.open |= active
        return done

    def observe(self, rewards: torch.Tensor, terminated: torch.Tensor, truncated: torch.Tensor,
                final_obs: torch.Tensor) -> Transitions:
        """A step's outcome per row: rewards add to the open transitions; a row whose agent ended closes its
        transition at ``final_obs`` (returned)."""
        self.rewards += torch.where(self.open, rewards.float(), torch.zeros_like(self.rewards))
        ended = (terminated | truncated) & self.open
        done = Transitions(self.obs[ended], self.actions[ended], self.rewards[ended], final_obs[ended].float(),
                           terminated[ended], truncated[ended] & ~terminated[ended], ended.nonzero().squeeze(-1))
        self.open &= ~(terminated | truncated)
        return done

    def clear(self) -> None:
        """Fresh episodes everywhere: no open transitions."""
        self.open.zero_()
        self.rewards.zero_()


class NStepRows:
    """n-step returns over each row's own transitions (an agent's steps, its waits left out): each transition
    sums the discounted rewards of the row's next ``n`` transitions (``n`` drawn per transition from
    ``[n_step, n_step_max]`` when that is given) and ends at the last one's ``next_obs``, or earlier at the agent's
    end. :meth:`add` returns the finished ones and their discounts (gamma ** steps)."""

    def __init__(self, rows: int, n_step: int, n_step_max: int | None, gamma: float) -> None:
        self.n_step, self.n_step_max, self.gamma = n_step, n_step_max, gamma
        self.pending: list[list[dict]] = [[] for _ in range(rows)]  # each row's open n-step transitions, oldest first

    def _draw(self) -> int:
        if self.n_step_max is None or self.n_step_max <= self.n_step:
            return self.n_step
        return int(torch.randint(self.n_step, self.n_step_max + 1, ()))

    def add(self, done: Transitions) -> tuple[Transitions, torch.Tensor]:
        """One-step transitions of some rows in; the n-step transitions they finish out, with their discounts."""
        out: list[tuple] = []
        for j, row in enumerate(done.rows.tolist()):
            queue = self.pending[row]
            queue.append({"obs": done.obs[j], "actions": done.actions[j], "n": self._draw(), "ret": 0.0, "k": 0})
            reward, ended = float(done.rewards[j]), bool(done.terminated[j] or done.truncated[j])
            for entry in queue:
                entry["ret"] += self.gamma ** entry["k"] * reward
                entry["k"] += 1
            keep = []
            for entry in queue:
                if ended or entry["k"] >= entry["n"]:
                    out.append((entry, j, row))
                else:
                    keep.append(entry)
            self.pending[row] = keep
        if not out:
            empty = done.rows[:0]
            return Transitions(done.obs[:0], done.actions[:0], done.rewards[:0], done.next_obs[:0],
                               done.terminated[:0], done.truncated[:0], empty), done.rewards[:0]
        picks = torch.tensor([j for _, j, _ in out], dtype=torch.long, device=done.rows.device)
        finished = Transitions(torch.stack([e["obs"] for e, _, _ in out]),
                               torch.stack([e["actions"] for e, _, _ in out]),
                               torch.tensor([e["ret"] for e, _, _ in out], dtype=torch.float32, device=picks.device),
                               done.next_obs[picks], done.terminated[picks], done.truncated[picks],
                               torch.tensor([r for _, _, r in out], dtype=torch.long, device=picks.device))
        discounts = torch.tensor([self.gamma ** e["k"] for e, _, _ in out], dtype=torch.float32, device=picks.device)
        return finished, discounts

    def clear(self) -> None:
        """Fresh episodes everywhere: the open n-step transitions are dropped."""
        self.pending = [[] for _ in self.pending]
