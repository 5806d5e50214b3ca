"""rl_games' ``sac_helper``: ``SquashedNormal``, the tanh-squashed Gaussian its SAC actor returns."""

from __future__ import annotations

import torch
from torch.distributions import Normal, TanhTransform, TransformedDistribution


class SquashedNormal(TransformedDistribution):
    """tanh(Normal(loc, scale)); ``mean`` is tanh(loc), ``base_dist`` the Normal (``loc``, ``scale``)."""

    def __init__(self, loc: torch.Tensor, scale: torch.Tensor) -> None:
        self.loc, self.scale = loc, scale
        super().__init__(Normal(loc, scale), [TanhTransform(cache_size=1)], validate_args=False)

    @property
    def mean(self) -> torch.Tensor:
        return torch.tanh(self.loc)

    def entropy(self) -> torch.Tensor:
        """The base Normal's entropy (rl_games' estimate: the tanh correction left out)."""
        return self.base_dist.entropy()


__all__ = ["SquashedNormal"]
