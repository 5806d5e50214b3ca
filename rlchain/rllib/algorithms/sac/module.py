"""The face's SAC policy under RLlib's module calls: ``action_dist_inputs`` are the squashed Gaussian's
pre-tanh means then log-stds (RLlib's ``TorchSquashedGaussian`` inputs) on Box actions, the categorical's logits
on Discrete ones; actions come from rlchain's SAC model."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from rlchain.rllib.module import ACTION_DIST_INPUTS, RLModuleView


class SACModuleView(RLModuleView):
    """RLModuleView of rlchain's ``SoftActorCritic`` (Box) or ``DiscreteSoftActorCritic``."""

    @torch.no_grad()
    def forward_inference(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, torch.Tensor]:
        """{"obs": (B, *obs_shape)} -> {"action_dist_inputs"}: (B, 2 * A) means then log-stds, before tanh; or
        (B, n) logits."""
        return {ACTION_DIST_INPUTS: self.model.action_dist_inputs(self.model.preprocess(self._obs(batch)))}

    forward_exploration = forward_inference

    @torch.no_grad()
    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> torch.Tensor:
        """min(Q1, Q2) at the deterministic action, (B,)."""
        return self.model(self._obs(batch))[1][..., 0]

    @torch.no_grad()
    def act(self, obs: Any, explore: bool) -> Any:
        """One action: in the env's bounds, sampled from the squashed Gaussian or tanh(mean); or an int, sampled
        from the categorical or its argmax."""
        out = self.model.act(self._obs({"obs": np.asarray(obs)[None]}), deterministic=not explore)
        action = self.model.dist.to_env(out["actions"])[0].cpu().numpy()
        return int(action) if action.ndim == 0 else action
