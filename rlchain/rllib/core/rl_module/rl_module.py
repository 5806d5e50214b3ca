"""``ray.rllib.core.rl_module.rl_module``: ``RLModuleSpec`` (data) and the ``RLModule`` base (a subclass can be
written; passing it through ``rl_module(rl_module_spec=...)`` is refused in one line: the face builds its
network from ``model_config``)."""

from __future__ import annotations

import torch

from rlchain.rllib.module import RLModuleSpec


class RLModule(torch.nn.Module):
    """RLlib's module base: ``setup``, ``_forward``, ``_forward_train`` (not trained by the face)."""

    framework = "torch"

    def __init__(self, *, observation_space=None, action_space=None, inference_only=False, model_config=None,
                 catalog_class=None, **kwargs) -> None:
        super().__init__()
        self.observation_space = observation_space
        self.action_space = action_space
        self.inference_only = inference_only
        self.model_config = model_config or {}
        self.setup()

    def setup(self) -> None:
        pass


__all__ = ["RLModule", "RLModuleSpec"]
