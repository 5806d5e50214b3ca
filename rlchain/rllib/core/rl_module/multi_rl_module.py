"""``ray.rllib.core.rl_module.multi_rl_module``: ``MultiRLModuleSpec`` (one ``RLModuleSpec`` per policy) as data."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from rlchain.rllib.core.rl_module.rl_module import RLModule, RLModuleSpec


@dataclass
class MultiRLModuleSpec:
    """RLlib's multi-module spec: ``rl_module_specs`` maps a policy (module) id to its ``RLModuleSpec``; one spec
    instead of a dict stands for every policy."""

    multi_rl_module_class: Any = None
    observation_space: Any = None
    action_space: Any = None
    inference_only: bool = False
    model_config: Any = None
    rl_module_specs: Any = field(default_factory=dict)
    load_state_path: Any = None
    modules_to_load: Any = None

    def spec_of(self, module_id: str) -> RLModuleSpec | None:
        """The spec of ``module_id`` (None: RLlib's default module)."""
        if isinstance(self.rl_module_specs, RLModuleSpec):
            return self.rl_module_specs
        return (self.rl_module_specs or {}).get(module_id)


class MultiRLModule(RLModule):
    """RLlib's container of modules by id (the face trains one module per policy; see docs/rllib.md)."""

    def setup(self) -> None:
        raise TypeError("MultiRLModule is not built by rlchain's RLlib face: give each policy an RLModuleSpec in "
                        "MultiRLModuleSpec(rl_module_specs={...})")


__all__ = ["MultiRLModule", "MultiRLModuleSpec"]
