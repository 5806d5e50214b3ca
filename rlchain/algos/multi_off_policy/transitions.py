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
                           torch.zeros_like(self.rewards[rows], dtype=torch.bool))
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
                           terminated[ended], truncated[ended] & ~terminated[ended])
        self.open &= ~(terminated | truncated)
        return done

    def clear(self) -> None:
        """Fresh episodes everywhere: no open transitions."""
        self.open.zero_()
        self.rewards.zero_()
