"""One actor-critic model for every action space: network + distribution + normalizers.

rl_games' model names (``discrete_a2c``, ``continuous_a2c_logstd``, ``continuous_a2c``) are presets
that choose the distribution (see :func:`rlchain.models.distributions.make_distribution`).
"""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.models.base import ObservationModel
from rlchain.models.distributions import Distribution
from rlchain.models.normalization import RunningMeanStd


class ActorCritic(ObservationModel):
    """Wraps a network (rl_games output tuple) into act / evaluate calls.

    Values are in the normalized space when ``normalize_value`` is on; ``denorm_value`` maps
    them back to returns. Observations are normalized here, once, with frozen statistics:
    :meth:`update_normalizers` folds a batch in after an update.
    """

    def __init__(self, network: nn.Module, dist: Distribution, obs_shape: tuple[int, ...],
                 value_size: int, normalize_input: bool, normalize_value: bool) -> None:
        super().__init__()
        self.network = network
        self.dist = dist
        self.obs_norm = RunningMeanStd(obs_shape) if normalize_input else None
        self.value_norm = RunningMeanStd((value_size,), clip=0.0) if normalize_value else None

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """obs (B, *obs_shape) -> (dist params (B, P), value (B, value_size))."""
        out = self.network({"obs": self.preprocess(obs)})
        return self.dist.params_from_network(out)

    @torch.inference_mode()
    def act(self, obs: torch.Tensor, deterministic: bool = False) -> dict[str, torch.Tensor]:
        """Rollout step: actions, their log-probs, raw-scale values and the distribution params."""
        params, value = self(obs)
        actions = self.dist.mode(params) if deterministic else self.dist.sample(params)
        return {"actions": actions, "log_probs": self.dist.log_prob(params, actions),
                "values": self.denorm_value(value), "params": params}

    @torch.inference_mode()
    def value(self, obs: torch.Tensor) -> torch.Tensor:
        """Raw-scale state values (B, value_size)."""
        return self.denorm_value(self(obs)[1])

    def denorm_value(self, value: torch.Tensor) -> torch.Tensor:
        return self.value_norm.denormalize(value) if self.value_norm is not None else value

    def norm_value(self, value: torch.Tensor) -> torch.Tensor:
        return self.value_norm.normalize(value) if self.value_norm is not None else value

    def update_normalizers(self, obs: torch.Tensor | None = None, returns: torch.Tensor | None = None) -> None:
        """Fold a batch of observations / raw returns into the running statistics."""
        super().update_normalizers(obs=obs)
        if returns is not None and self.value_norm is not None:
            self.value_norm.update(returns)

    def override_sigma(self, sigma: float) -> None:
        """``--sigma``: set a fixed (input-independent) sigma to a constant standard deviation."""
        param = getattr(self.network, "sigma", None)
        if not isinstance(param, nn.Parameter):
            raise ValueError("--sigma needs a continuous policy with fixed_sigma: True")
        value = torch.log(torch.tensor(sigma)) if getattr(self.dist, "sigma_is_logstd", False) else sigma
        with torch.no_grad():
            param.fill_(float(value))
