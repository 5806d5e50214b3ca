"""DQN (algo ``dqn``): the off-policy loop of :mod:`~rlchain.algos.off_policy.off_policy` with the
:class:`~rlchain.algos.off_policy.dqn_agent.DQNAgent` (a Q network, a target network, epsilon-greedy
exploration)."""

from __future__ import annotations

import torch

from rlchain.algos.off_policy.dqn_agent import DQNAgent, epsilon_at
from rlchain.algos.off_policy.off_policy import OffPolicyAlgorithm
from rlchain.config.off_policy import DQNConfig


class DQN(OffPolicyAlgorithm):
    """Algo ``dqn``."""

    config_class = DQNConfig
    metric_tags = {"td_loss": "losses/td_loss", "q": "info/q", "epsilon": "info/epsilon",
                   **OffPolicyAlgorithm.SHARED_TAGS}
    console_fields = tuple((name, name + " {:.3g}") for name in ("td_loss", "q", "epsilon"))
    tunable = ("learning_rate", "gamma", "target_tau", "target_update_frequency", "batch_size",
               "num_updates_per_step", "epsilon_end")

    def make_agent(self) -> DQNAgent:
        return DQNAgent(self.model, self.cfg)

    def epsilon(self) -> float:
        cfg = self.cfg
        return epsilon_at(self.ctx.frames - cfg.num_warmup_frames, cfg.epsilon_start, cfg.epsilon_end,
                          cfg.epsilon_decay_frames)

    def explore(self, obs: torch.Tensor) -> torch.Tensor:
        return self.model.act(obs, epsilon=self.epsilon())["actions"]

    def extra_stats(self) -> dict[str, float]:
        return {"epsilon": self.epsilon()}
