"""SAC (algo ``sac``): the off-policy loop of :mod:`~rlchain.algos.off_policy.off_policy` with the
:class:`~rlchain.algos.off_policy.sac_agent.SACAgent` (a squashed-Gaussian actor, twin critics, a learned
temperature)."""

from __future__ import annotations

from rlchain.algos.off_policy.off_policy import OffPolicyAlgorithm
from rlchain.algos.off_policy.sac_agent import SACAgent
from rlchain.config.off_policy import SACConfig


class SAC(OffPolicyAlgorithm):
    """Algo ``sac``."""

    config_class = SACConfig
    metric_tags = {"actor_loss": "losses/actor_loss", "critic_loss": "losses/critic_loss",
                   "alpha_loss": "losses/alpha_loss", "entropy": "losses/entropy", "q": "info/q",
                   "alpha": "info/alpha", **OffPolicyAlgorithm.SHARED_TAGS}
    console_fields = tuple((name, name + " {:.3g}") for name in
                           ("actor_loss", "critic_loss", "alpha_loss", "entropy", "q", "alpha"))
    tunable = ("actor_lr", "critic_lr", "alpha_lr", "gamma", "critic_tau", "batch_size", "num_updates_per_step",
               "policy_frequency")

    def make_agent(self) -> SACAgent:
        return SACAgent(self.model, self.cfg)

    def extra_stats(self) -> dict[str, float]:
        stats = {"alpha": float(self.model.alpha.detach())}
        if self.agent.rllib_stats:  # RLlib's results report it (rlchain's own logs do not)
            stats["target_entropy"] = self.agent.target_entropy
        return stats
