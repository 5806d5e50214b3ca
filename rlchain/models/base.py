"""What every model shares: observation preprocessing and the input normalizer."""

from __future__ import annotations

import torch
import torch.nn as nn

from rlchain.envs.obs_dict import ObsDict
from rlchain.models.normalization import RunningMeanStd, dict_as_float


def as_float(obs: torch.Tensor) -> torch.Tensor:
    """uint8 images -> float32 in [0, 1]; any other dtype -> float32 (no copy when already)."""
    if obs.dtype == torch.uint8:
        return obs.float() / 255.0
    return obs if obs.dtype == torch.float32 else obs.float()


class ObservationModel(nn.Module):
    """uint8 images -> float in [0, 1], optional flattening, then input normalization when on.

    Subclasses set ``self.running_mean_std`` (a RunningMeanStd or None) and may set ``flatten_obs``.
    ``obs_slice`` picks this model's part of ``[obs | state]`` observations (asymmetric critic:
    the actor reads ``[:obs_size]``, the central value ``[obs_size:]``; see envs/wrappers/central_value.py).
    """

    flatten_obs = False
    obs_slice: slice | tuple[int, ...] | None = None
    flatten_dict: bool = False
    """Dict observations kept per key (an ObsDict) are concatenated into one float vector for a network that
    takes a flat input (images scaled to [0, 1] first); a multi-input network gets them per key."""
    obs_group: str | None = None
    """The ``obs_groups`` group this model reads (set when the config names groups; export then takes the view)."""
    running_mean_std: RunningMeanStd | None  # set by the subclass (a registered submodule or None)

    def read_view(self, obs_slice: slice | tuple[int, ...] | None, obs_group: str | None, flatten_dict: bool) -> None:
        """The part of the env's observations this model reads, given by the builder that made it
        (:func:`rlchain.models.build.build_model`, before anything uses the model): ``obs_slice``, the
        ``obs_groups`` group it names (``obs_group``) and whether Dict observations are concatenated for it."""
        self.obs_slice, self.obs_group, self.flatten_dict = obs_slice, obs_group, flatten_dict

    def preprocess(self, obs: torch.Tensor) -> torch.Tensor:
        """The network input: this model's part of obs, as float, [0, 1] for uint8, normalized when on.

        With a normalizer the uint8 scaling folds into it (one pass over the frames, not five).
        """
        obs = self.view(obs)
        if isinstance(obs, ObsDict):  # kept per key: images scaled, vectors normalized each by its own statistics
            return self.running_mean_std.normalize(obs) if self.running_mean_std is not None else dict_as_float(obs)
        if self.running_mean_std is None:
            return self._features(obs)
        scale = 1.0 / 255.0 if obs.dtype == torch.uint8 else 1.0
        x = obs if obs.dtype == torch.float32 else obs.float()
        return self.running_mean_std.normalize(x.flatten(1) if self.flatten_obs else x, scale)

    def view(self, obs: torch.Tensor) -> torch.Tensor:
        """This model's part of the env's flat observations (B, total) -> (B, view): its ``obs_slice``."""
        if isinstance(obs, ObsDict):  # a network that wants one flat vector gets the keys concatenated
            return dict_as_float(obs).flatten(1) if self.flatten_dict else obs
        if self.obs_slice is None:
            return obs
        if isinstance(self.obs_slice, slice):
            return obs[:, self.obs_slice]
        return obs.index_select(1, torch.tensor(self.obs_slice, device=obs.device))

    def _features(self, obs: torch.Tensor) -> torch.Tensor:
        """float32 obs ([0, 1] for uint8), flattened when the model flattens: what the normalizer sees."""
        obs = as_float(obs)
        return obs.flatten(1) if self.flatten_obs else obs

    def update_normalizers(self, obs: torch.Tensor | None = None, returns: torch.Tensor | None = None) -> None:
        """Fold a batch of observations (rows) into the input statistics (models with values add returns)."""
        if obs is not None and self.running_mean_std is not None:
            # the same part and [0, 1] scale that preprocess() normalizes, converted chunk by chunk
            self.running_mean_std.update(self.view(obs), self._features)

    def denorm_value(self, value: torch.Tensor) -> torch.Tensor:
        """Values in raw return scale (identity unless a value normalizer exists)."""
        return value


VALUE_NORMALIZERS = ("rl_games", "returns")
"""``config.value_normalizer``: rl_games = statistics of the rollout's value predictions and its returns,
normalized values clipped to +-5 (rl_games' value_mean_std); returns = statistics of the returns, no clip."""
VALUE_NORM_CLIP = 5.0  # rl_games' RunningMeanStd clamp, in normalized units


def value_normalizer(value_size: int, normalize_value: bool, kind: str) -> RunningMeanStd | None:
    """The value normalizer of ``config.value_normalizer`` ``kind`` (None when normalize_value is off)."""
    if kind not in VALUE_NORMALIZERS:
        raise ValueError(f"params.config.value_normalizer: expected one of {', '.join(VALUE_NORMALIZERS)}, "
                         f"got {kind!r}")
    if not normalize_value:
        return None
    return RunningMeanStd((value_size,), clip=VALUE_NORM_CLIP if kind == "rl_games" else 0.0)


class ValueModel(ObservationModel):
    """A model with a value output: ``self.value_mean_std`` (a RunningMeanStd or None) maps between the
    return scale and the normalized scale the value head learns in.

    ``fold_values`` (``value_normalizer: rl_games``): the rollout's value predictions join the returns in
    the statistics, and a clipping normalizer also clamps the head's output before denormalizing it, as
    rl_games does (so the value head learns on rl_games' scale; docs/ppo_parity.md).
    """

    value_mean_std: RunningMeanStd | None  # set by the subclass
    fold_values: bool = False

    def denorm_value(self, value: torch.Tensor) -> torch.Tensor:
        """Normalized values -> return scale (the head's output clamped to +-clip first when it clips)."""
        if self.value_mean_std is None:
            return value
        if self.value_mean_std.clip > 0:
            value = value.clamp(-self.value_mean_std.clip, self.value_mean_std.clip)
        return self.value_mean_std.denormalize(value)

    def norm_value(self, value: torch.Tensor) -> torch.Tensor:
        """Return-scale values -> the normalized scale."""
        return self.value_mean_std.normalize(value) if self.value_mean_std is not None else value

    def update_normalizers(self, obs: torch.Tensor | None = None, returns: torch.Tensor | None = None,
                           values: torch.Tensor | None = None) -> None:
        """Fold a batch of observations / raw returns into the running statistics, and the rollout's
        raw value predictions (rows, value_size) first when ``fold_values``."""
        super().update_normalizers(obs=obs)
        if self.value_mean_std is None:
            return
        if values is not None and self.fold_values:
            self.value_mean_std.update(values)
        if returns is not None:
            self.value_mean_std.update(returns)
