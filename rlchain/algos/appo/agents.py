"""The learners of appo and impala: the PPO agent (optimizer, lr schedules, value and entropy losses) on V-trace
advantages, with APPO's KL penalty against a target policy, or IMPALA's policy gradient instead of the clipped
surrogate."""

from __future__ import annotations

import torch

from rlchain.algos.core.losses import vtrace_policy_loss
from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.ppo.agent import PPOAgent


class APPOAgent(PPOAgent):
    """PPO's clipped surrogate of pi/mu on V-trace's advantages. With ``kl_loss_coef`` > 0 the KL penalty is
    measured against the target policy whose distribution parameters the learner wrote into the batch's
    ``params`` (:class:`rlchain.algos.appo.appo.APPO`), whatever ``kl_reference`` says, and its coefficient
    adapts after every pass over the batch, as RLlib's APPO adapts it after every learner update."""

    kl_adapt_each_pass = True

    def _kl_reference(self, storage: RolloutStorage) -> torch.Tensor | None:
        if self._kl_coef_t is not None:
            return None  # the target policy's params, as the batch holds them
        return super()._kl_reference(storage)


class ImpalaAgent(PPOAgent):
    """Trains on batches whose advantages are V-trace's ``pg_advantages`` (the ratio clip is inside them)."""

    surrogate = staticmethod(vtrace_policy_loss)
