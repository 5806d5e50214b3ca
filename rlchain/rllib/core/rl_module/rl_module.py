"""``ray.rllib.core.rl_module.rl_module``: ``RLModule`` and ``RLModuleSpec``, with RLlib's calling convention.

A user's module is written as RLlib's docs show: ``setup()`` builds the layers from ``self.observation_space``,
``self.action_space`` and ``self.model_config``; ``_forward`` (or ``_forward_inference`` / ``_forward_exploration``
/ ``_forward_train``) maps ``{"obs": batch}`` to ``{"action_dist_inputs": ...}``; the public ``forward_*`` calls
dispatch to them. The face trains such a module under PPO as an rlchain network
(:mod:`rlchain.rllib.module_network`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import torch

from rlchain.rllib.module import RLModuleSpec
from rlchain.rllib.module_checkpoint import from_checkpoint as module_from_checkpoint


class RLModule(torch.nn.Module):
    """RLlib's module base (torch only). Subclasses override :meth:`setup` and the ``_forward*`` methods, never
    the constructor's work: the constructor sets the spaces and ``model_config`` (a dict), then calls ``setup``."""

    framework = "torch"

    def __init__(self, config: Any = None, *, observation_space: Any = None, action_space: Any = None,
                 inference_only: bool | None = None, learner_only: bool = False, model_config: Any = None,
                 catalog_class: Any = None, **kwargs: Any) -> None:
        if config is not None:
            raise TypeError(f"{type(self).__name__}: RLModule(config=RLModuleConfig) is RLlib's removed API; pass "
                            f"observation_space=, action_space=, model_config= (RLModuleSpec does)")
        torch.nn.Module.__init__(self)
        self.observation_space = observation_space
        self.action_space = action_space
        self.inference_only = bool(inference_only)
        self.learner_only = learner_only
        if dataclasses.is_dataclass(model_config):
            model_config = dataclasses.asdict(model_config)
        self.model_config = dict(model_config or {})
        self.catalog = None
        self.catalog_class = catalog_class
        if getattr(self, "_is_setup", False):
            raise RuntimeError(f"{type(self).__name__}: setup() ran twice; override setup(), not __init__'s work")
        self.setup()
        self._is_setup = True

    def setup(self) -> None:
        """Build the module's layers (override)."""

    @classmethod
    def from_checkpoint(cls, path: Any, **kwargs: Any) -> Any:
        """The trained module of a face checkpoint for inference: ``<checkpoint>/learner_group/learner/rl_module``
        gives ``{module id: module}``, ``.../rl_module/<module id>`` the module (see
        :mod:`rlchain.rllib.module_checkpoint`)."""
        return module_from_checkpoint(path)

    # ----- forward passes: the public call dispatches to the override --------------------------------------------
    def _forward(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        """The one forward pass used by the three below unless they are overridden."""
        raise NotImplementedError(f"{type(self).__name__}: override _forward (or _forward_inference, "
                                  f"_forward_exploration and _forward_train)")

    def forward_inference(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        return self._forward_inference(batch, **kwargs)

    def _forward_inference(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        return self._forward(batch, **kwargs)

    def forward_exploration(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        return self._forward_exploration(batch, **kwargs)

    def _forward_exploration(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        return self._forward(batch, **kwargs)

    def forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        if self.inference_only:
            raise RuntimeError(f"{type(self).__name__}: forward_train on an inference_only module")
        return self._forward_train(batch, **kwargs)

    def _forward_train(self, batch: dict[str, Any], **kwargs: Any) -> dict[str, Any]:
        return self._forward(batch, **kwargs)

    # ----- state ------------------------------------------------------------------------------------------------
    def get_initial_state(self) -> Any:
        return {}

    def is_stateful(self) -> bool:
        return bool(self.get_initial_state())

    def get_state(self, components: Any = None, *, not_components: Any = None, inference_only: bool = False,
                  **kwargs: Any) -> dict[str, Any]:
        """The weights as numpy arrays (RLlib's module state)."""
        return {k: v.detach().cpu().numpy() for k, v in self.state_dict().items()}

    def set_state(self, state: dict[str, Any]) -> None:
        self.load_state_dict({k: torch.as_tensor(v) for k, v in state.items()})

    def unwrapped(self) -> RLModule:
        return self


def build_module(spec: RLModuleSpec) -> RLModule:
    """``RLModuleSpec.build()``: the spec's class on its spaces and model_config."""
    if spec.module_class is None:
        raise ValueError("RLModuleSpec.build(): no module_class")
    return spec.module_class(observation_space=spec.observation_space, action_space=spec.action_space,
                             inference_only=spec.inference_only, learner_only=spec.learner_only,
                             model_config=spec.model_config, catalog_class=spec.catalog_class)


RLModuleSpec.build = build_module  # the spec is data in rlchain.rllib.module; building needs this module


__all__ = ["RLModule", "RLModuleSpec"]
