"""What the face's DQN and SAC share: their rlchain agent computes the statistics only RLlib's results report, and
their ``learners/<module>`` results keep RLlib's target-update counters across ``train()`` calls
(:mod:`rlchain.rllib.off_policy_results`)."""

from __future__ import annotations

from typing import Any

from rlchain.rllib.algorithm import Algorithm
from rlchain.rllib.off_policy_results import TargetUpdates


class OffPolicyAlgorithm(Algorithm):
    """An RLlib off-policy algorithm on rlchain's off-policy loop (DQN, SAC)."""

    def __init__(self, config: Any = None, env: Any = None, logger_creator: Any = None, **kwargs: Any) -> None:
        super().__init__(config, env, logger_creator, **kwargs)
        # the run is parked before its first rollout: its agent exists and has made no gradient step
        agent = getattr(self._stepper.context, "agent", None)
        for one in (getattr(agent, "agents", None) or {}).values() or [agent]:  # multi-agent: each policy's agent
            if hasattr(one, "rllib_stats"):
                one.rllib_stats = True  # rlchain's DQN / SAC agents skip RLlib's extra statistics otherwise


def target_updates(algo: Any) -> TargetUpdates:
    """``algo``'s RLlib target-update counters (:class:`TargetUpdates`), made on first use."""
    return algo.__dict__.setdefault("_target_updates", TargetUpdates())
