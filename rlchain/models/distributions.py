"""Action distributions. Every action-space difference lives here, none in the algorithm.

A distribution works on a flat parameter tensor ``params`` (B, param_size) that the rollout
storage keeps for the KL term: logits for Categorical, ``cat(mu, sigma)`` for DiagGaussian.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import torch


class Distribution:
    """Interface used by the PPO loss, the rollout and the Player."""

    param_size: int
    action_shape: tuple[int, ...]
    action_dtype: torch.dtype

    def params_from_network(self, out: tuple) -> tuple[torch.Tensor, torch.Tensor]:
        """Split a network's output tuple into (params, value)."""
        raise NotImplementedError

    def sample(self, params: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def mode(self, params: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def log_prob(self, params: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def entropy(self, params: torch.Tensor) -> torch.Tensor:
        raise NotImplementedError

    def kl(self, old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
        """KL(old || new) per sample."""
        raise NotImplementedError

    def log_prob_and_entropy(self, params: torch.Tensor, actions: torch.Tensor
                             ) -> tuple[torch.Tensor, torch.Tensor]:
        """Both at once (the PPO loss needs both; subclasses share the work)."""
        return self.log_prob(params, actions), self.entropy(params)

    def bounds_loss(self, params: torch.Tensor, kind: str) -> torch.Tensor:
        """Auxiliary loss keeping continuous means in range; zero for discrete actions."""
        return torch.zeros(params.shape[0], device=params.device)

    def to_env(self, actions: torch.Tensor) -> torch.Tensor:
        """Map sampled actions to what the env accepts (clip/rescale for Box)."""
        return actions


class Categorical(Distribution):
    """Discrete(n): params are logits (B, n); actions are int64 (B,)."""

    def __init__(self, n: int) -> None:
        self.param_size = n
        self.action_shape = ()
        self.action_dtype = torch.long

    def params_from_network(self, out: tuple) -> tuple[torch.Tensor, torch.Tensor]:
        return out[0], out[1]

    @staticmethod
    def _log_softmax(params: torch.Tensor) -> torch.Tensor:
        return torch.log_softmax(params, -1)

    def sample(self, params: torch.Tensor) -> torch.Tensor:
        # Gumbel-max: one argmax, cheaper than multinomial for small batches on CPU
        u = torch.rand_like(params).clamp_(1e-20, 1.0)
        return (params - (-u.log()).log()).argmax(-1)

    def mode(self, params: torch.Tensor) -> torch.Tensor:
        return params.argmax(-1)

    def log_prob(self, params: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        return self._log_softmax(params).gather(-1, actions.long().unsqueeze(-1)).squeeze(-1)

    def entropy(self, params: torch.Tensor) -> torch.Tensor:
        logp = self._log_softmax(params)
        return -(logp.exp() * logp).sum(-1)

    def log_prob_and_entropy(self, params: torch.Tensor, actions: torch.Tensor
                             ) -> tuple[torch.Tensor, torch.Tensor]:
        logp = self._log_softmax(params)
        return logp.gather(-1, actions.long().unsqueeze(-1)).squeeze(-1), -(logp.exp() * logp).sum(-1)

    def kl(self, old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
        old_logp, new_logp = self._log_softmax(old), self._log_softmax(new)
        return (old_logp.exp() * (old_logp - new_logp)).sum(-1)


class DiagGaussian(Distribution):
    """Box(A): params are cat(mu, std) (B, 2A); the network's sigma is log-std or std by model."""

    def __init__(self, space: gym.spaces.Box, sigma_is_logstd: bool, clip_actions: bool) -> None:
        self.action_shape = space.shape
        self.dim = int(np.prod(space.shape))
        self.param_size = 2 * self.dim
        self.action_dtype = torch.float32
        self.sigma_is_logstd = sigma_is_logstd
        self.clip_actions = clip_actions
        low = np.asarray(space.low, dtype=np.float64).reshape(-1)
        high = np.asarray(space.high, dtype=np.float64).reshape(-1)
        finite = np.isfinite(low).all() and np.isfinite(high).all()
        self.rescale = clip_actions and finite
        self._low = torch.as_tensor(low, dtype=torch.float32)
        self._high = torch.as_tensor(high, dtype=torch.float32)

    def params_from_network(self, out: tuple) -> tuple[torch.Tensor, torch.Tensor]:
        mu, sigma, value = out[0], out[1], out[2]
        std = sigma.exp() if self.sigma_is_logstd else sigma
        return torch.cat([mu, std], -1), value

    def _split(self, params: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return params[..., : self.dim], params[..., self.dim:]

    def sample(self, params: torch.Tensor) -> torch.Tensor:
        mu, std = self._split(params)
        return mu + std * torch.randn_like(mu)

    def mode(self, params: torch.Tensor) -> torch.Tensor:
        return self._split(params)[0]

    def log_prob(self, params: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        mu, std = self._split(params)
        z = (actions - mu) / std
        return (-0.5 * z * z - std.log() - 0.5 * math.log(2 * math.pi)).sum(-1)

    def entropy(self, params: torch.Tensor) -> torch.Tensor:
        std = self._split(params)[1]
        return (0.5 + 0.5 * math.log(2 * math.pi) + std.log()).sum(-1)

    def kl(self, old: torch.Tensor, new: torch.Tensor) -> torch.Tensor:
        mu0, std0 = self._split(old)
        mu1, std1 = self._split(new)
        return (torch.log(std1 / std0) + (std0.square() + (mu0 - mu1).square()) / (2 * std1.square())
                - 0.5).sum(-1)

    def bounds_loss(self, params: torch.Tensor, kind: str) -> torch.Tensor:
        mu = self._split(params)[0]
        if kind == "regularisation":
            return mu.square().sum(-1)
        soft = 1.1
        return ((mu - soft).clamp_min(0).square() + (mu + soft).clamp_max(0).square()).sum(-1)

    def to_env(self, actions: torch.Tensor) -> torch.Tensor:
        """With clip_actions: clip to [-1, 1] and rescale linearly to [low, high]."""
        if not self.rescale:
            return actions
        low, high = self._low.to(actions.device), self._high.to(actions.device)
        clipped = actions.clamp(-1.0, 1.0)
        return low + (clipped + 1.0) * 0.5 * (high - low)


def make_distribution(model_name: str, space: gym.Space, clip_actions: bool) -> Distribution:
    """The distribution a model preset uses for ``space``; a clear error on a mismatch."""
    if isinstance(space, gym.spaces.Discrete):
        if model_name not in ("discrete_a2c",):
            raise ValueError(f"params.model.name: '{model_name}' needs continuous actions, the env has "
                             f"Discrete({space.n}); use discrete_a2c")
        return Categorical(int(space.n))
    if isinstance(space, gym.spaces.Box):
        if model_name not in ("continuous_a2c_logstd", "continuous_a2c"):
            raise ValueError(f"params.model.name: '{model_name}' needs discrete actions, the env has "
                             f"Box{space.shape}; use continuous_a2c_logstd")
        return DiagGaussian(space, sigma_is_logstd=model_name == "continuous_a2c_logstd",
                            clip_actions=clip_actions)
    raise ValueError(f"action space {space} is not supported yet (MultiDiscrete/Tuple: issue 3)")
