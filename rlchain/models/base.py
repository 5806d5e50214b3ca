"""What every model shares: observation preprocessing and the input normalizer."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.models.normalization import RunningMeanStd


class ObservationModel(nn.Module):
    """uint8 images -> float in [0, 1], optional flattening, then input normalization when on.

    Subclasses set ``self.obs_norm`` (a RunningMeanStd or None) and may set ``flatten_obs``.
    """

    flatten_obs = False
    obs_norm: RunningMeanStd | None  # set by the subclass (a registered submodule or None)

    def preprocess(self, obs: torch.Tensor) -> torch.Tensor:
        if obs.dtype == torch.uint8:
            obs = obs.float() / 255.0
        elif obs.dtype != torch.float32:
            obs = obs.float()
        if self.flatten_obs:
            obs = obs.flatten(1)
        return self.obs_norm.normalize(obs) if self.obs_norm is not None else obs

    def update_normalizers(self, obs: torch.Tensor | None = None, returns: torch.Tensor | None = None) -> None:
        """Fold a batch of observations into the input statistics (models with values add returns)."""
        if obs is not None and self.obs_norm is not None:
            obs = obs.float()
            self.obs_norm.update(obs.flatten(1) if self.flatten_obs else obs)

    def denorm_value(self, value: torch.Tensor) -> torch.Tensor:
        """Values in raw return scale (identity unless a value normalizer exists)."""
        return value
