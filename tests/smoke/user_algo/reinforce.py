"""A user's own algorithm for rlchain's Loop: REINFORCE with a mean-return baseline.

What adding an algorithm takes, and all it takes: this module (the Algorithm protocol's hooks, on
``AlgorithmBase``'s defaults), one config class and one registration line (``model_builder.register_algo``
in this package's ``__init__.py``, user code). The Loop holds the algorithm and supplies stop rules,
signals, checkpoints and resume, the divergence guard, callbacks, evaluation and the TensorBoard /
console logging of the metrics ``update`` returns; the run (env steps, counters, stop signals) reaches
the algorithm through ``self.ctx``, the RunContext.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch

from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard
from rlchain.algos.core.returns import shape_rewards
from rlchain.config.fields import option
from rlchain.config.schema import Params, PPOConfig


@dataclass(frozen=True)
class ReinforceConfig(PPOConfig):
    """PPO's keys (horizon_length, learning_rate, gamma, ...) plus this algorithm's own."""

    baseline: bool = option(True, "subtract the batch's mean return from every return")


class ReinforceAgent:
    """The optimizer, with what the Loop's divergence guard and checkpoints need of an agent."""

    def __init__(self, model: torch.nn.Module, lr: float) -> None:
        self.optimizer = torch.optim.Adam(model.parameters(), lr=lr)

    @property
    def lr(self) -> float:
        return self.optimizer.param_groups[0]["lr"]

    def scale_lr(self, factor: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] *= factor

    def state_dict(self) -> dict[str, Any]:
        return {"optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.optimizer.load_state_dict(state["optimizer"])


class ReinforceTrainer(AlgorithmBase):
    """Algo ``reinforce``: horizon_length steps of every env, then one policy-gradient step."""

    config_class = ReinforceConfig
    metric_tags = {"pg_loss": "losses/pg_loss", "mean_return": "info/mean_return", "lr": "info/last_lr"}
    console_fields = (("pg_loss", "pg_loss {:.3g}"),)
    tunable = ("learning_rate", "gamma")

    def __init__(self, params: Params, env: Any, model: torch.nn.Module, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        self.agent = ReinforceAgent(self.model, self.cfg.learning_rate)
        self.divergence = DivergenceGuard(self.cfg.divergence, self.model, self.agent)
        self.batch: dict[str, torch.Tensor] = {}

    def collect(self) -> bool:
        cfg, model, ctx = self.cfg, self.model, self.ctx
        model.eval()
        obs, actions, rewards, dones = [], [], [], []
        for _ in range(cfg.horizon_length):
            if ctx.stop_requested():
                return False
            with torch.no_grad():
                out = model.act(self.obs)
            result = self.env.step(ctx.env_actions(model.dist.to_env(out["actions"])))
            reward, _, _, done = ctx.env_outcome(result)
            rs = cfg.reward_shaper
            obs.append(self.obs)
            actions.append(out["actions"])
            rewards.append(shape_rewards(reward, rs.scale_value, rs.shift_value, rs.min_val, rs.max_val, rs.log_val))
            dones.append(done)
            self.obs = ctx.to_tensor(result.obs)
        self.batch = {"obs": torch.stack(obs), "actions": torch.stack(actions), "rewards": torch.stack(rewards),
                      "dones": torch.stack(dones)}
        return True

    def update(self) -> dict[str, float]:
        cfg, model, b = self.cfg, self.model, self.batch
        returns = torch.zeros_like(b["rewards"])
        running = torch.zeros_like(b["rewards"][0])
        for t in reversed(range(cfg.horizon_length)):  # the horizon's end cuts episodes: no bootstrap
            running = b["rewards"][t] + cfg.gamma * running * (~b["dones"][t]).float()
            returns[t] = running
        advantages = returns - returns.mean() if cfg.baseline else returns
        model.train()
        params, _, _ = model.evaluate(b["obs"].flatten(0, 1))
        log_probs, _ = model.dist.log_prob_and_entropy(params, b["actions"].flatten(0, 1))
        loss = -(log_probs * advantages.flatten()).mean()
        self.agent.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.agent.optimizer.step()
        self.ctx.frames += cfg.horizon_length * self.num_envs
        return {"pg_loss": float(loss), "mean_return": float(returns.mean()), "lr": self.agent.lr}

    def frames_per_epoch(self) -> int:
        return self.cfg.horizon_length * self.num_envs

    def hyperparams(self) -> dict[str, float]:
        return {"learning_rate": self.agent.lr, "gamma": self.cfg.gamma}

    def apply_hyperparam(self, name: str, value: float) -> None:
        if name == "learning_rate":
            for group in self.agent.optimizer.param_groups:
                group["lr"] = float(value)
        else:
            super().apply_hyperparam(name, value)
