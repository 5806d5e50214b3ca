"""IMPALA's learner: the PPO agent (optimizer, lr schedules, value and entropy losses) with V-trace's
policy gradient instead of the clipped surrogate."""

from __future__ import annotations

from rlchain.algos.core.losses import vtrace_policy_loss
from rlchain.algos.ppo.agent import PPOAgent


class ImpalaAgent(PPOAgent):
    """Trains on batches whose advantages are V-trace's ``pg_advantages`` (the ratio clip is inside them)."""

    surrogate = staticmethod(vtrace_policy_loss)
