"""PPO pieces for agents that are not always there: returns and minibatches over active steps only.

A multi-agent rollout row (one agent of one env) is *active* at step t when that agent acted at t.
An agent that died, has not appeared yet, or waits for its turn (turn-based games) is inactive:
its steps carry no transition. They are skipped, never padded: the advantage of an active step
chains to the row's next active step, with the rewards the agent got in between summed into it
(a turn-based move's reward is what happened until the agent's next move), and only active steps
reach the loss, the advantage normalization and the normalizers. A recurrent policy trains on whole sequences
(its states run through every step, as in the rollout), the inactive steps weighing 0 in the loss.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

import torch

from rlchain.algos.core.losses import normalize_advantages
from rlchain.algos.core.storage import Batch, RolloutStorage
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.config.ppo import PPOConfig


def masked_gae(rewards: torch.Tensor, values: torch.Tensor, final_values: torch.Tensor,
               last_values: torch.Tensor, active: torch.Tensor, terminated: torch.Tensor,
               dones: torch.Tensor, gamma: float, lam: float) -> tuple[torch.Tensor, torch.Tensor]:
    """GAE over each row's active steps. Returns (advantages, returns), zero at inactive steps.

    Shapes: rewards, values, final_values (T, N, V); last_values (N, V) (V of each row's current
    observation, the bootstrap after the rollout); active, terminated, dones (T, N) bool.
    ``dones[t]``: the row's agent ended at step t (``terminated[t]``: a true terminal, else the
    value of its final observation ``final_values[t]`` is bootstrapped). With every step active
    this is :func:`rlchain.algos.core.returns.gae`.
    """
    next_value = last_values.clone()
    next_adv = torch.zeros_like(last_values)
    pending = torch.zeros_like(last_values)  # rewards since the row's next active step
    advantages = torch.zeros_like(values)
    for t in range(values.shape[0] - 1, -1, -1):
        done = dones[t].unsqueeze(-1)
        boot = torch.where(terminated[t].unsqueeze(-1), torch.zeros_like(next_value), final_values[t])
        next_value = torch.where(done, boot, next_value)
        next_adv = torch.where(done, torch.zeros_like(next_adv), next_adv)
        pending = torch.where(done, torch.zeros_like(pending), pending) + rewards[t]
        adv = pending + gamma * next_value - values[t] + gamma * lam * next_adv
        act = active[t].unsqueeze(-1)
        advantages[t] = torch.where(act, adv, torch.zeros_like(adv))
        next_value = torch.where(act, values[t], next_value)
        next_adv = torch.where(act, adv, next_adv)
        pending = torch.where(act, torch.zeros_like(pending), pending)
    return advantages, torch.where(active.unsqueeze(-1), advantages + values, torch.zeros_like(values))


def active_minibatches(storage: RolloutStorage, active: torch.Tensor, minibatch_size: int,
                       advantages: torch.Tensor) -> Iterator[Batch]:
    """Shuffled flat minibatches of the active steps only: round(active / minibatch_size) of them
    (at least one), of near-equal size, so the minibatch size stays near the configured one
    however many agents were present."""
    size = storage.horizon * storage.num_envs
    idx = active.reshape(-1).nonzero().squeeze(-1)
    if idx.numel() == 0:
        return
    per_step = storage._per_step(advantages)
    flat = {k: v.reshape(size, *v.shape[2:]) for k, v in per_step.items()}
    order = idx[torch.randperm(idx.numel(), device=idx.device)]
    count = max(1, round(idx.numel() / minibatch_size))
    for chunk in order.tensor_split(count):
        yield Batch(**{k: v.index_select(0, chunk) for k, v in flat.items()}, index=chunk)


def active_sequences(storage: RolloutStorage, active: torch.Tensor, cfg: PPOConfig,
                     advantages: torch.Tensor) -> Iterator[Batch]:
    """An RNN policy's minibatches: whole sequences of ``seq_length`` steps (the RNN runs over every step, as it
    did in the rollout), each step weighted by whether it is active, so only active steps reach the loss means;
    a minibatch without an active step is left out."""
    flat = active.reshape(-1)
    for batch in storage.sequence_minibatches(cfg.minibatch_size, cfg.seq_length, advantages,
                                              use_resets=cfg.zero_rnn_on_done):
        weights = flat.index_select(0, batch.index).float()
        if bool(weights.any()):
            yield dataclasses.replace(batch, weights=weights)


class MaskedPPOAgent(PPOAgent):
    """:class:`PPOAgent` that learns from the active steps only: ``active``, the (T, N) bool mask its policy's
    rollout fills in place (None: every step)."""

    def __init__(self, model: Any, cfg: PPOConfig, device: torch.device, active: torch.Tensor | None = None) -> None:
        super().__init__(model, cfg, device)
        self.active = active

    def _batch_advantages(self, storage: RolloutStorage) -> torch.Tensor:
        advantages = storage.advantages.sum(-1)
        if self.cfg.normalize_advantage and self.active is not None and bool(self.active.any()):
            mask = self.active
            picked = normalize_advantages(advantages[mask])
            advantages = torch.zeros_like(advantages)
            advantages[mask] = picked
        return advantages

    def _minibatches(self, storage: RolloutStorage, advantages: torch.Tensor) -> Iterator[Batch]:
        if self.model.is_rnn:
            return active_sequences(storage, self.active, self.cfg, advantages)
        return active_minibatches(storage, self.active, self.cfg.minibatch_size, advantages)
