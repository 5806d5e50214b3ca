"""``ray.rllib.policy.policy``: ``PolicySpec``, a multi-agent policy entry of ``.multi_agent(policies={...})``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass
class PolicySpec:
    """RLlib's policy entry: the face reads it as "one policy" (spaces come from the env; a ``config`` override is
    refused in one line, rlchain.rllib.multi_agent)."""

    policy_class: Any = None
    observation_space: Any = None
    action_space: Any = None
    config: Any = None


__all__ = ["PolicySpec"]
