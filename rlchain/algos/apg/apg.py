"""``algo: apg``: analytic policy gradients (EmbodiChain's APG). Each epoch is one segment of
``horizon_length`` steps of a differentiable tensor env: actions are reparameterised samples (or the mean)
of the policy, rewards keep their graph back to the policy's parameters through the env's dynamics, and the
loss is minus the mean discounted segment return (minus ``entropy_coef`` times the discounted entropy).
After the optimizer step the env's ``detach_state()`` cuts the graph (truncated backpropagation); episodes
go on across segments, finished ones auto-reset inside the env's step."""

from __future__ import annotations

import dataclasses
from functools import partial
from typing import Any

import torch

from rlchain.algos.apg.objective import discounted_segment_return
from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard
from rlchain.algos.core.adam_agent import AdamAgent, loss_stats
from rlchain.algos.core.collector import CollectedStep, OnPolicyCollector, StepOutcome, as_is
from rlchain.config.apg import APGConfig
from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.envs.vecenv import VecEnv
from rlchain.errors import DivergenceError


class APG(AlgorithmBase):
    """Algo ``apg`` (see the module docstring)."""

    config_class = APGConfig
    metric_tags = {"loss": "losses/apg_loss", "objective": "info/objective", "entropy": "losses/entropy",
                   "grad_norm": "info/grad_norm", "skipped_update": "info/skipped_update", "lr": "info/last_lr"}
    console_fields = (("objective", "objective {:.3g}"), ("grad_norm", "grad {:.3g}"))
    tunable = ("learning_rate", "entropy_coef", "grad_norm", "gamma")

    def __init__(self, params: Params, env: VecEnv, model: torch.nn.Module, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        if not ctx.spec.tensor_native or not callable(getattr(env, "detach_state", None)):
            raise ConfigError(params.source, "params.config.env_name",
                              f"APG needs a differentiable tensor env with detach_state() (TorchPointMass-v0, "
                              f"TorchPendulum-v0, an EmbodiChain-contract env with detach_state); "
                              f"{type(env).__name__} has none")
        if not model.dist.continuous or model.is_rnn:
            raise ConfigError(params.source, "params.model.name", "APG trains feed-forward continuous policies "
                                                                  "(continuous_a2c_logstd)")
        self.agent = AdamAgent(model, self.cfg.learning_rate, self.cfg.weight_decay, ctx.comm, self.cfg.lr_schedule,
                               self.cfg.min_lr)
        self.divergence = DivergenceGuard(self.cfg.divergence, model, self.agent)
        self.stats: dict[str, float] = {}
        self.segment: dict[str, list[torch.Tensor]] = {}
        # a differentiable rollout: raw actions into the tensor env, observations and rewards keep their graph
        self.collector = OnPolicyCollector(env, model, ctx, self.cfg, act=self._act, to_env=as_is,
                                           record=self._record, read_obs=as_is, on_step=self._on_step,
                                           differentiable=True)

    def collect(self) -> bool:
        """One segment (the on-policy collector, differentiable): act, step, keep the graph; then the optimizer
        step and the cut."""
        cfg = self.cfg
        self.model.train()
        self.segment = {"rewards": [], "dones": [], "entropies": []}
        if not self.collector.rollout():
            return False
        segment = self.segment
        segment_return, _ = discounted_segment_return(segment["rewards"], segment["dones"], cfg.gamma)
        entropy, _ = discounted_segment_return(segment["entropies"], segment["dones"], cfg.gamma)
        objective, mean_entropy = segment_return.mean(), entropy.mean()
        loss = -objective - cfg.entropy_coef * mean_entropy
        self.stats = self._step(loss)
        self.stats.update(objective=float(objective.detach()), entropy=float(mean_entropy.detach()),
                          loss=float(loss.detach()))
        self.segment = {}
        self.collector.place(self.env.detach_state())
        return True

    def _act(self, t: int, obs: torch.Tensor, states: tuple, masks: torch.Tensor | None) -> dict[str, Any]:
        """The collector's act step: a reparameterised sample of the policy (or its mean), with its graph."""
        params, _, _ = self.model.evaluate(obs)
        mu, std = params.chunk(2, -1)
        action = mu if self.cfg.deterministic_actions else mu + std * torch.randn_like(mu)
        return {"actions": action, "params": params}

    def _record(self, result: Any, rows: slice) -> StepOutcome:
        """The episode statistics and callbacks see a detached copy of the step."""
        return self.ctx.record_step(dataclasses.replace(result, reward=result.reward.detach(),
                                                        obs=result.obs.detach()), rows)

    def _on_step(self, step: CollectedStep) -> None:
        """The segment keeps each step's rewards (with their graph), ends and policy entropy."""
        self.segment["rewards"].append(step.result.reward)
        self.segment["dones"].append(step.outcome[3])
        self.segment["entropies"].append(self.model.dist.entropy(step.out["params"]))

    def _step(self, loss: torch.Tensor) -> dict[str, float]:
        """The segment's optimizer step; a non-finite loss or gradient skips it (``skip_nonfinite_updates``) or
        raises DivergenceError."""
        agent, cfg = self.agent, self.cfg
        try:
            step = agent.step(loss, cfg.grad_norm if cfg.truncate_grads else float("inf"),
                              partial(loss_stats, loss), "the APG segment's step")
        except DivergenceError:
            if not cfg.skip_nonfinite_updates:
                raise
            return {"grad_norm": float("nan"), "skipped_update": 1.0, "lr": agent.lr}
        agent.apply_progress(self.progress())
        return {"grad_norm": step["grad_norm"], "skipped_update": 0.0, "lr": agent.lr}

    def update(self) -> dict[str, float]:
        """The segment's step was taken in :meth:`collect`; report it."""
        return dict(self.stats)

    def frames_per_epoch(self) -> int:
        return self.cfg.horizon_length * self.num_envs

    def start(self) -> None:
        super().start()
        self.collector.place(self.collector.obs.detach())

    def restart_episodes(self) -> None:
        super().restart_episodes()
        self.collector.place(self.collector.obs.detach())
