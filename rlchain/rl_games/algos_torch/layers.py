"""rl_games' ``algos_torch.layers``: noisy linear layers (NoisyNet exploration) and the symlog transform.

``NoisyLinear`` adds independent Gaussian noise to every weight, ``NoisyFactorizedLinear`` factorised noise
(one vector per input and per output), each with a learned scale; fresh noise is drawn at every forward pass.
"""

from __future__ import annotations

import math

import torch
import torch.nn as nn
import torch.nn.functional as F


class NoisyLinear(nn.Linear):
    """Linear layer whose weight and bias carry learned-scale independent Gaussian noise."""

    def __init__(self, in_features: int, out_features: int, sigma_init: float = 0.017, bias: bool = True) -> None:
        super().__init__(in_features, out_features, bias=bias)
        self.sigma_weight = nn.Parameter(torch.full((out_features, in_features), sigma_init))
        self.register_buffer("epsilon_weight", torch.zeros(out_features, in_features))
        if bias:
            self.sigma_bias = nn.Parameter(torch.full((out_features,), sigma_init))
            self.register_buffer("epsilon_bias", torch.zeros(out_features))
        bound = math.sqrt(3 / in_features)
        with torch.no_grad():
            self.weight.uniform_(-bound, bound)
            if self.bias is not None:
                self.bias.uniform_(-bound, bound)

    def forward(self, input: torch.Tensor) -> torch.Tensor:
        self.epsilon_weight.normal_()
        bias = self.bias
        if bias is not None:
            self.epsilon_bias.normal_()
            bias = bias + self.sigma_bias * self.epsilon_bias
        return F.linear(input, self.weight + self.sigma_weight * self.epsilon_weight, bias)


class NoisyFactorizedLinear(nn.Linear):
    """Linear layer with factorised noise: the weight noise is f(eps_out) f(eps_in)^T, f(x) = sign(x) sqrt|x|."""

    def __init__(self, in_features: int, out_features: int, sigma_zero: float = 0.4, bias: bool = True) -> None:
        super().__init__(in_features, out_features, bias=bias)
        sigma_init = sigma_zero / math.sqrt(in_features)
        self.sigma_weight = nn.Parameter(torch.full((out_features, in_features), sigma_init))
        self.register_buffer("epsilon_input", torch.zeros(1, in_features))
        self.register_buffer("epsilon_output", torch.zeros(out_features, 1))
        if bias:
            self.sigma_bias = nn.Parameter(torch.full((out_features,), sigma_init))

    def forward(self, input: torch.Tensor) -> torch.Tensor:
        self.epsilon_input.normal_()
        self.epsilon_output.normal_()
        eps_in, eps_out = _signed_sqrt(self.epsilon_input), _signed_sqrt(self.epsilon_output)
        bias = self.bias
        if bias is not None:
            bias = bias + self.sigma_bias * eps_out.t().squeeze(0)
        return F.linear(input, self.weight + self.sigma_weight * (eps_out @ eps_in), bias)


def _signed_sqrt(x: torch.Tensor) -> torch.Tensor:
    return torch.sign(x) * torch.sqrt(torch.abs(x))


def symlog(x: torch.Tensor) -> torch.Tensor:
    """sign(x) log(1 + |x|): compresses large magnitudes, keeps the sign."""
    return torch.sign(x) * torch.log1p(torch.abs(x))


def symexp(x: torch.Tensor) -> torch.Tensor:
    """The inverse of :func:`symlog`."""
    return torch.sign(x) * torch.expm1(torch.abs(x))


class SymLog(nn.Module):
    def forward(self, input: torch.Tensor) -> torch.Tensor:
        return symlog(input)


class SymExp(nn.Module):
    def forward(self, input: torch.Tensor) -> torch.Tensor:
        return symexp(input)
