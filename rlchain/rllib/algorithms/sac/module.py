"""The face's SAC policy under RLlib's module calls: ``action_dist_inputs`` are the squashed Gaussian's
pre-tanh means then log-stds (RLlib's ``TorchSquashedGaussian`` inputs), actions come from rlchain's SAC model."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from rlchain.algos.off_policy.sac_agent import actor_params
from rlchain.rllib.module import ACTION_DIST_INPUTS, RLModuleView


class SACModuleView(RLModuleView):
    """RLModuleView of rlchain's ``SoftActorCritic``."""

    @torch.no_grad()
    def forward_inference(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, torch.Tensor]:
        """{"obs": (B, *obs_shape)} -> {"action_dist_inputs": (B, 2 * A)}: means then log-stds, before tanh."""
        mu, log_std = actor_params(self.model.network.actor, self.model.preprocess(self._obs(batch)))
        return {ACTION_DIST_INPUTS: torch.cat([mu, log_std], -1)}

    forward_exploration = forward_inference

    @torch.no_grad()
    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> torch.Tensor:
        """min(Q1, Q2) at the deterministic action, (B,)."""
        return self.model(self._obs(batch))[1][..., 0]

    @torch.no_grad()
    def act(self, obs: Any, explore: bool) -> Any:
        """One action in the env's bounds: sampled from the squashed Gaussian, or tanh(mean)."""
        out = self.model.act(self._obs({"obs": np.asarray(obs)[None]}), deterministic=not explore)
        return self.model.dist.to_env(out["actions"])[0].cpu().numpy()
