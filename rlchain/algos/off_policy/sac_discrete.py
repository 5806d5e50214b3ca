"""Soft actor-critic for Discrete actions (Christodoulou 2019, "Soft Actor-Critic for Discrete Action Settings";
RLlib's SAC on a Discrete space): a categorical policy over the n actions and twin critics with one Q-value per
action, so every expectation over the policy's actions is a sum over the n actions weighted by their
probabilities instead of a sampled action.

With per-sample p = softmax(logits) (B, n) and Q = min(Q1, Q2) (B, n):

- the soft value (critic target at the next observation, actor objective): sum_a p (Q - alpha log p),
  computed as its two parts ``q_pi`` = sum_a p Q and ``logp_pi`` = sum_a p log p (:func:`expected_terms`);
- the critic of the stored action: Q1, Q2 gathered at it (:func:`taken_q`);
- the temperature loss uses ``logp_pi`` = -entropy of the categorical, as the continuous SAC uses the sampled
  log-probability.

:class:`DiscreteSoftActorCritic` answers the same calls as the Box model
(:class:`~rlchain.algos.off_policy.sac_agent.SoftActorCritic`), so one SAC update serves both.
"""

from __future__ import annotations

import math

import gymnasium as gym
import torch
import torch.nn as nn

from rlchain.algos.off_policy.sac_agent import SoftActorCritic
from rlchain.models.distributions import Categorical


def expected_terms(logits: torch.Tensor, q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """A categorical policy's (E[log p], E[Q]) per sample, each (B,), from logits (B, n) and Q-values (B, n):
    sums over the actions weighted by softmax(logits). ``E[Q] - alpha * E[log p]`` is the soft value."""
    log_p = torch.log_softmax(logits, -1)
    p = log_p.exp()
    return (p * log_p).sum(-1), (p * q).sum(-1)


def taken_q(q1: torch.Tensor, q2: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Each critic's Q-value (B,) at the stored actions (B,) (int indices), from their Q-values (B, n)."""
    index = actions.long().reshape(-1, 1)
    return q1.gather(-1, index).squeeze(-1), q2.gather(-1, index).squeeze(-1)


def discrete_target_entropy(n: int, scale: float = 0.98) -> float:
    """rlchain's default temperature target for Discrete(n): ``scale`` x the uniform policy's entropy log(n)
    (Christodoulou 2019 uses 0.98)."""
    return scale * math.log(n)


class CategoricalSACActions(Categorical):
    """The model's ``dist`` as the Player sees it: logits (B, n), int64 actions (B,); uniform warmup actions."""

    def random(self, num: int, device: torch.device) -> torch.Tensor:
        """Uniform action indices (B,) (warmup)."""
        return torch.randint(0, self.param_size, (num,), device=device)


class DiscreteSoftActorCritic(SoftActorCritic):
    """network (``actor``: obs -> logits (B, n); ``critic``: obs -> (q1, q2), each (B, n)), ``critic_target``,
    ``log_alpha`` and the obs normalizer."""

    def make_dist(self, action_space: gym.Space, clip_actions: bool) -> CategoricalSACActions:
        return CategoricalSACActions(int(action_space.n), int(action_space.start))

    @property
    def default_target_entropy(self) -> float:
        """0.98 log(n) (:func:`discrete_target_entropy`)."""
        return discrete_target_entropy(self.dist.param_size)

    def policy(self, obs: torch.Tensor, deterministic: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
        """Preprocessed obs -> (action indices (B,), their log-probability (B,)); deterministic = argmax."""
        logits = self.network.actor(obs)
        actions = self.dist.mode(logits) if deterministic else self.dist.sample(logits)
        return actions, self.dist.log_prob(logits, actions)

    def soft_terms(self, critic: nn.Module, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(E[log p], E[min(Q1, Q2)]) over the policy's actions, each (B,) (:func:`expected_terms`)."""
        q1, q2 = critic(obs)
        return expected_terms(self.network.actor(obs), torch.min(q1, q2))

    def taken_q(self, critic: nn.Module, obs: torch.Tensor, actions: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
        """(q1, q2), each (B,), at the stored actions."""
        return taken_q(*critic(obs), actions)

    def action_dist_inputs(self, obs: torch.Tensor) -> torch.Tensor:
        """Preprocessed obs -> the categorical's logits (B, n) (RLlib's ``TorchCategorical`` inputs)."""
        return self.network.actor(obs)

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """obs -> (logits (B, n), value (B, 1)) in the ActorCritic protocol that export uses: ``dist.mode(logits)``
        is the greedy action, value = min(Q1, Q2) at it."""
        x = self.preprocess(obs)
        logits = self.network.actor(x)
        q1, q2 = taken_q(*self.network.critic(x), logits.argmax(-1))
        return logits, torch.min(q1, q2).unsqueeze(-1)

    def override_sigma(self, sigma: float) -> None:
        raise ValueError("--sigma is not supported by soft_actor_critic with Discrete actions (a categorical policy)")
