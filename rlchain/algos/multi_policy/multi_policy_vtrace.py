"""Multi-policy appo / impala: PettingZoo agents, each played by its policy, each policy a V-trace learner.

:class:`~rlchain.algos.multi_policy.multi_policy.MultiPolicyPPO`'s rollout, per-policy models, optimizers,
storages, masks and tags, with each trained policy learning as ``appo`` / ``impala`` does: V-trace targets and
advantages over its active steps (:func:`~rlchain.algos.multi_policy.masked_vtrace.masked_vtrace`), then APPO's
clipped surrogate (``mini_epochs`` passes, the KL penalty against the policy before the update) or IMPALA's
policy gradient. The envs are stepped in the learner's process between updates (no runner threads or actors):
every batch is sampled by the policy being trained, so V-trace's ratios pi/mu are 1 (its targets are the
n-step returns to the rollout's end, cut by episode ends) and the ``appo`` block's runner keys have nothing to
act on. Recurrent policies keep their states as multi-policy PPO's do.
"""

from __future__ import annotations

from typing import ClassVar

import torch

from rlchain.algos.appo.agents import APPOAgent, ImpalaAgent
from rlchain.algos.multi_policy.masked import MaskedPPOAgent
from rlchain.algos.multi_policy.masked_vtrace import masked_vtrace
from rlchain.algos.multi_policy.multi_policy import MultiPolicyPPO
from rlchain.algos.multi_policy.policies import PolicyLearner
from rlchain.config.actor_critic import check_batch
from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.envs.spec import EnvSpec


class MaskedAPPOAgent(MaskedPPOAgent, APPOAgent):
    """APPO's learner on the active steps only."""


class MaskedImpalaAgent(MaskedPPOAgent, ImpalaAgent):
    """IMPALA's learner on the active steps only."""


class MultiPolicyAPPO(MultiPolicyPPO):
    """``algo: appo`` with ``config.multi_agent`` (see the module docstring)."""

    agent_class = MaskedAPPOAgent
    pg_advantages: ClassVar[bool] = False
    """IMPALA: the ratio-weighted policy-gradient advantages; APPO: q - V (its surrogate weighs by pi/mu)."""

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        """What the multi-policy V-trace learner does not have yet: a one-line ConfigError."""
        cfg = params.config
        unsupported = [  # the runners: refused at load time (VTraceConfig.validate)
            ("vecenv_type", str(cfg.vecenv_type).lower() == "ray"),
            ("evaluation.interval", cfg.evaluation.interval > 0),
            ("target_update_interval", getattr(cfg, "kl_loss_coef", 0.0) > 0
             and getattr(cfg, "target_update_interval", 1) > 1)]
        for key, used in unsupported:
            if used:
                raise ConfigError(params.source, f"params.config.{key}", "is not supported with multi_agent yet "
                                  "(the envs are stepped in the learner's process, the KL penalty's target is the "
                                  "policy before each update); remove it (docs/multi_agent.md)")
        check_batch(cfg, params.source, spec.num_agents)

    def advantages(self, lr: PolicyLearner) -> tuple[torch.Tensor, torch.Tensor]:
        """(advantages, V-trace targets) over the policy's active steps. The batch was sampled by the weights and
        normalizer statistics it is valued with (both change only in the update), feed-forward or recurrent
        alike, so the log-ratios of pi to mu are 0 here; the update's passes measure theirs against the
        stored behaviour log-probs as APPO does."""
        storage, cfg = lr.storage, lr.cfg
        out = masked_vtrace(torch.zeros_like(storage.log_probs), storage.rewards, storage.values, storage.final_values,
                            lr.last_values, lr.active, storage.terminated, storage.dones, cfg.gamma,
                            cfg.appo.vtrace_clip_rho, cfg.appo.vtrace_clip_c)
        return (out.pg_advantages if self.pg_advantages else out.advantages), out.vs


class MultiPolicyIMPALA(MultiPolicyAPPO):
    """``algo: impala`` with ``config.multi_agent``: the V-trace actor-critic, one pass per batch."""

    agent_class = MaskedImpalaAgent
    pg_advantages = True
