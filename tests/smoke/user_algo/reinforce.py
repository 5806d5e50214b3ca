"""A user's own algorithm for rlchain's Loop: REINFORCE with a mean-return baseline.

What adding an algorithm takes, and all it takes: this module (a config class and the algorithm's
``update``, on ``AlgorithmBase``'s defaults for the other hooks) and one registration line
(``model_builder.register_algo`` in this package's ``__init__.py``, user code). The on-policy collector
steps the envs into a rollout storage (episode statistics, callbacks, stop signals included); the Loop
holds the algorithm and supplies stop rules, signals, checkpoints and resume, the divergence guard,
callbacks, evaluation and the TensorBoard / console logging of the metrics ``update`` returns; the run
(counters, the env's outcome) reaches the algorithm through ``self.ctx``, the RunContext.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch

from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard
from rlchain.algos.core.adam_agent import AdamAgent
from rlchain.algos.core.collector import OnPolicyCollector
from rlchain.algos.core.storage import RolloutStorage
from rlchain.config.fields import option, positive
from rlchain.config.params import Params
from rlchain.config.run import RunConfig


@dataclass(frozen=True)
class ReinforceConfig(RunConfig):
    """The keys every algorithm reads (RunConfig: env, num_actors, gamma, reward_shaper, stop rules, ...)
    plus REINFORCE's own."""

    horizon_length: int = option(32, "steps per env per epoch", check=positive)
    learning_rate: float = option(3e-4, "Adam learning rate", check=positive)
    baseline: bool = option(True, "subtract the batch's mean return from every return")


class Reinforce(AlgorithmBase):
    """Algo ``reinforce``: the collector's rollout of horizon_length steps of every env, then one
    policy-gradient step."""

    config_class = ReinforceConfig
    metric_tags = {"pg_loss": "losses/pg_loss", "mean_return": "info/mean_return", "lr": "info/last_lr"}
    console_fields = (("pg_loss", "pg_loss {:.3g}"),)
    tunable = ("learning_rate", "gamma")

    def __init__(self, params: Params, env: Any, model: torch.nn.Module, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        cfg, dist = self.cfg, model.dist
        # the agent (rlchain.algos.core.adam_agent.Agent: lr, scale_lr, state_dict, load_state_dict) is what the
        # Loop's checkpoints and divergence guard use; AdamAgent keeps that contract and takes the optimizer step
        self.agent = AdamAgent(self.model, cfg.learning_rate)
        self.divergence = DivergenceGuard(cfg.divergence, self.model, self.agent)
        storage = RolloutStorage(cfg.horizon_length, self.num_envs, tuple(env.observation_space.shape),
                                 torch.float32, dist.action_shape, dist.action_dtype, dist.param_size, 1, self.device)
        self.collector = OnPolicyCollector(env, model, ctx, cfg, storage=storage)

    def collect(self) -> bool:  # where the envs stand lives in the collector (AlgorithmBase's start places it)
        return self.collector.rollout()

    def update(self) -> dict[str, float]:
        cfg, model, rollout = self.cfg, self.model, self.collector.storage
        rewards, dones = rollout.rewards[..., 0], rollout.dones
        returns = torch.zeros_like(rewards)
        running = torch.zeros_like(rewards[0])
        for t in reversed(range(cfg.horizon_length)):  # the horizon's end cuts episodes: no bootstrap
            running = rewards[t] + cfg.gamma * running * (~dones[t]).float()
            returns[t] = running
        advantages = returns - returns.mean() if cfg.baseline else returns
        model.train()
        params, _, _ = model.evaluate(rollout.obs.flatten(0, 1))
        log_probs, _ = model.dist.log_prob_and_entropy(params, rollout.actions.flatten(0, 1))
        loss = -(log_probs * advantages.flatten()).mean()
        self.agent.step(loss)
        return {"pg_loss": float(loss), "mean_return": float(returns.mean()), "lr": self.agent.lr}

    def frames_per_epoch(self) -> int:
        return self.cfg.horizon_length * self.num_envs

    def hyperparams(self) -> dict[str, float]:
        return {"learning_rate": self.agent.lr, "gamma": self.cfg.gamma}

    def apply_hyperparam(self, name: str, value: float) -> None:
        if name == "learning_rate":
            self.agent.set_lr(value)
        else:
            super().apply_hyperparam(name, value)
