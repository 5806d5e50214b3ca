"""``ray.rllib.core.rl_module.apis.value_function_api``: ``ValueFunctionAPI``."""

from __future__ import annotations

from typing import Any


class ValueFunctionAPI:
    """A module with a value function: ``compute_values(batch, embeddings=None) -> (B,)`` (PPO needs it)."""

    def compute_values(self, batch: dict[str, Any], embeddings: Any = None) -> Any:
        raise NotImplementedError(f"{type(self).__name__}: implement compute_values(batch, embeddings=None)")


__all__ = ["ValueFunctionAPI"]
