"""``algo: distill``: a student learns to act like a frozen teacher on the states it visits itself (DAgger).

Each epoch (:meth:`Distill.collect`) steps the envs ``horizon_length`` times. Who acts is drawn with
DAgger's beta (``teacher_action_prob``, moving linearly to ``teacher_action_prob_end`` over
``teacher_action_prob_epochs``) once per episode or every step (``mixing``); the teacher labels every
state either way (its action distribution on its own, clean, view). The student reads its view
(``obs_groups.student``), corrupted by ``student_noise_std`` / ``student_dropout`` and ``student_delay``
steps late while training.
:meth:`Distill.update` then fits the student to the labels (``loss``: MSE / Huber on the action
means, KL or cross-entropy on the distributions; action masks applied to both sides) for ``mini_epochs``
passes; an RNN student is trained on each env's whole rollout from the state it entered the epoch with
(truncated BPTT: ``bptt_length``), its state zeroed where an episode started.

The loop's reward statistics (``rewards/*``, the best checkpoint, ``score_to_win``) count the episodes the
student played alone; ``rewards/teacher`` and ``rewards/student`` are the means of the last
``games_to_track`` episodes each played alone. The loop checkpoints the student (``model``); the checkpoint
also holds the teacher's weights and config (``teacher``), and ``--play`` / ``--export`` take the student alone.
"""

from __future__ import annotations

from collections import deque
from functools import partial
from typing import Any

import numpy as np
import torch

from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard
from rlchain.algos.core.adam_agent import AdamAgent, loss_stats
from rlchain.algos.core.behavior import behavior_loss, resolve_loss
from rlchain.algos.core.collector import CollectedStep, OnPolicyCollector, StepOutcome
from rlchain.algos.core.schedules import linear_decay
from rlchain.algos.distill.student_obs import (
    DelayLine,
    cat_envs,
    corrupt,
    env_rows,
    merge_steps,
    stack_steps,
)
from rlchain.algos.distill.teacher import SACTeacher, load_teacher
from rlchain.config.distill import DistillConfig
from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.config.resolve import config_state
from rlchain.envs.vecenv import DROPPED, VecEnv


def _check_sac_student(source: str, dist: Any, teacher: SACTeacher) -> None:
    """A SAC teacher's student has continuous actions of the same size (one-line ConfigError otherwise); a SAC
    teacher of Discrete actions (a categorical policy: no ``dim``) labels none."""
    if getattr(teacher.dist, "dim", None) is None:
        raise ConfigError(source, "params.config.teacher_checkpoint",
                          "the SAC teacher acts with Discrete actions: a SAC teacher labels continuous actions only "
                          "(distil a discrete student from a PPO teacher)")
    if not getattr(dist, "continuous", False) or getattr(dist, "dim", None) != teacher.dist.dim:
        what = f"{dist.dim} continuous" if getattr(dist, "continuous", False) else "discrete"
        raise ConfigError(source, "params.config.teacher_checkpoint",
                          f"the SAC teacher acts with {teacher.dist.dim} continuous actions, the student has "
                          f"{what} ones: another action space")


def _concat_envs(batches: list[dict[str, Any]]) -> dict[str, Any]:
    """Rollouts of several epochs side by side: (T, N, ...) tensors concatenated along the env axis (RNN
    states along their batch axis 1)."""
    if len(batches) == 1:
        return batches[0]
    out: dict[str, Any] = {"obs": cat_envs([b["obs"] for b in batches])}  # per key for Dict observations
    for key in ("labels", "resets"):
        out[key] = torch.cat([b[key] for b in batches], 1)
    out["masks"] = torch.cat([b["masks"] for b in batches], 1) if batches[0]["masks"] is not None else None
    out["states"] = tuple(torch.cat(parts, 1) for parts in zip(*(b["states"] for b in batches)))
    return out


class Distill(AlgorithmBase):
    """Algo ``distill``: DAgger from a frozen PPO teacher into the student of ``params.network``."""

    config_class = DistillConfig
    metric_tags = {"behavior_loss": "losses/behavior", "teacher_action_prob": "info/teacher_action_prob",
                   "action_match": "info/action_match", "lr": "info/last_lr", "teacher_return": "rewards/teacher",
                   "student_return": "rewards/student"}
    console_fields = (("behavior_loss", "behavior {:.3g}"), ("teacher_action_prob", "beta {:.2f}"),
                      ("student_return", "student {:.1f}"), ("teacher_return", "teacher {:.1f}"))
    tunable = ("learning_rate",)
    supports_distributed = True  # multi_gpu: gradients averaged over the ranks, the student's normalizer pooled

    def __init__(self, params: Params, env: VecEnv, model: torch.nn.Module, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        cfg: DistillConfig = self.cfg
        self.teacher = load_teacher(params, env, self.device)
        teacher = self.teacher.model
        if isinstance(teacher, SACTeacher):
            _check_sac_student(params.source, model.dist, teacher)
            teacher.bind(model.dist)
        elif model.dist.param_size != teacher.dist.param_size:
            raise ConfigError(params.source, "params.config.teacher_checkpoint",
                              f"the teacher's action head has {teacher.dist.param_size} outputs, the "
                              f"student's {model.dist.param_size}: another action space")
        try:
            self.loss_kind = resolve_loss(cfg.loss, bool(model.dist.continuous))
        except ValueError as exc:
            raise ConfigError(params.source, "params.config.loss", str(exc)) from None
        if isinstance(teacher, SACTeacher) and self.loss_kind not in ("mse", "huber"):
            raise ConfigError(params.source, "params.config.loss",
                              f"{self.loss_kind} needs the teacher's action distribution; a SAC teacher labels "
                              f"with its deterministic action: use mse or huber (or auto)")
        self.use_masks = bool(getattr(model, "use_action_masks", False))
        self.agent = AdamAgent(model, cfg.learning_rate, cfg.weight_decay, ctx.comm)
        self.divergence = DivergenceGuard(cfg.divergence, model, self.agent)
        n, dev = self.num_envs, self.device
        self.collector = OnPolicyCollector(env, model, ctx, cfg, use_masks=self.use_masks, act=self._act,
                                           record=self._record, on_step=self._on_step)
        self.student_states = len(model.initial_state(n, dev))
        self.collector.place(None, self._initial_states())
        self.beta_now = 1.0
        self._steps: dict[str, list] = {}
        self.resets = torch.ones(n, dtype=torch.bool, device=dev)  # the first step starts an episode
        self.teacher_drives = torch.ones(n, dtype=torch.bool, device=dev)
        self.teacher_steps = torch.zeros(n, device=dev)  # steps the teacher acted in each running episode
        self.student_steps = torch.zeros(n, device=dev)
        self.returns = torch.zeros(n, device=dev)
        self.finished = {"teacher": deque(maxlen=cfg.games_to_track), "student": deque(maxlen=cfg.games_to_track)}
        self.batch: dict[str, Any] = {}
        self.dataset: deque[dict[str, Any]] = deque(maxlen=cfg.dataset_epochs)  # labelled rollouts kept
        self.delay = DelayLine(cfg.obs_groups.student_delay if cfg.obs_groups is not None else 0)

    def _initial_states(self) -> tuple:
        """Zero RNN states for every env: the student's, then the teacher's."""
        n, dev = self.num_envs, self.device
        return tuple(self.model.initial_state(n, dev)) + tuple(self.teacher.model.initial_state(n, dev))

    # -- the schedule --------------------------------------------------------------------------------------
    def beta(self) -> float:
        """DAgger's beta this epoch: the probability that the teacher acts."""
        cfg = self.cfg
        if cfg.teacher_action_prob_epochs == 0:
            return cfg.teacher_action_prob_end
        return linear_decay(cfg.teacher_action_prob, cfg.teacher_action_prob_end,
                            self.ctx.epoch / cfg.teacher_action_prob_epochs)

    def _draw(self, rows: torch.Tensor, beta: float) -> None:
        """Who drives the envs ``rows`` (bool (N,)) from now: the teacher with probability beta."""
        drawn = torch.rand(self.num_envs, device=self.device) < beta
        self.teacher_drives = torch.where(rows, drawn, self.teacher_drives)

    # -- collect -------------------------------------------------------------------------------------------
    def collect(self) -> bool:
        """One epoch of env steps (the on-policy collector): the teacher labels every state; the student or
        the teacher acts."""
        self.beta_now = self.beta()
        self._steps = {"obs": [], "labels": [], "resets": [], "masks": [], "match": []}
        self.batch = {"states": tuple(s.clone() for s in self.states)}
        if not self.collector.rollout():
            return False
        steps = self._steps
        self.batch.update(obs=stack_steps(steps["obs"]), labels=torch.stack(steps["labels"]),
                          resets=torch.stack(steps["resets"]),
                          masks=torch.stack(steps["masks"]) if steps["masks"] else None, beta=self.beta_now,
                          match=float(torch.stack(steps["match"]).mean()))
        return True

    def _act(self, t: int, obs: torch.Tensor, states: tuple, masks: torch.Tensor | None) -> dict[str, Any]:
        """The collector's act step: who drives is drawn, the teacher labels the state on its clean view, the
        student acts on its own (corrupted, delayed) view; the driver's action goes to the envs. ``states``:
        the student's RNN states, then the teacher's."""
        cfg, model, teacher = self.cfg, self.model, self.teacher.model
        groups = cfg.obs_groups
        noise, dropout = (groups.student_noise_std, groups.student_dropout) if groups is not None else (0.0, 0.0)
        if cfg.mixing == "step":
            self._draw(torch.ones_like(self.resets), self.beta_now)
        else:
            self._draw(self.resets, self.beta_now)
        student_obs = self.delay.push(corrupt(obs, noise, dropout), self.resets)
        s_states, t_states = states[:self.student_states], states[self.student_states:]
        with torch.no_grad():
            t_params, _, t_next = teacher.evaluate(self.teacher.select(obs), t_states or None, action_masks=masks)
            s_params, _, s_next = model.evaluate(student_obs, s_states or None, action_masks=masks)
        dist = model.dist
        t_action = dist.mode(t_params)
        s_action = dist.mode(s_params) if cfg.student_deterministic else dist.sample(s_params)
        drives = self.teacher_drives.view(-1, *([1] * (t_action.dim() - 1)))
        steps = self._steps
        steps["match"].append((s_action == t_action).reshape(self.num_envs, -1).all(-1).float().mean()
                              if not dist.continuous else (s_action - t_action).abs().mean())
        steps["obs"].append(student_obs)
        steps["labels"].append(t_params)
        steps["resets"].append(self.resets)
        if masks is not None:
            steps["masks"].append(masks)
        return {"actions": torch.where(drives, t_action, s_action), "states": tuple(s_next or ()) + tuple(t_next or ())}

    def _record(self, result: Any, rows: slice) -> StepOutcome:
        """The collector's recording: the step in the run's statistics, but for episodes not the student's
        alone (:meth:`_exclude_mixed`)."""
        self._exclude_mixed(result)
        return self.ctx.record_step(result, rows)

    def _on_step(self, step: CollectedStep) -> None:
        """After each step: the per-side returns, and which rows start an episode next."""
        rewards, _, _, dones = step.outcome
        self._track(rewards, dones)
        self.resets = dones

    @property
    def states(self) -> tuple:
        """The student's RNN states (carried by the collector, before the teacher's)."""
        return self.collector.rnn_states[:self.student_states]

    def _exclude_mixed(self, result: Any) -> None:
        """Keep the Loop's episode statistics to the episodes the student played alone: the others ending
        this step are marked dropped for its tracker (not recorded, not counted)."""
        if not isinstance(result.infos, dict):
            return
        acted = self.teacher_steps + self.teacher_drives.float()
        not_student = (acted > 0).cpu().numpy()
        old = result.infos.get(DROPPED)
        result.infos[DROPPED] = not_student if old is None else (np.asarray(old, bool) | not_student)

    def _track(self, rewards: torch.Tensor, dones: torch.Tensor) -> None:
        """Who acted this step and the raw returns: episodes played wholly by one side are recorded."""
        if rewards.dim() > 1:
            rewards = rewards.sum(-1)
        self.teacher_steps += self.teacher_drives.float()
        self.student_steps += (~self.teacher_drives).float()
        self.returns += rewards
        for i in dones.nonzero().flatten().tolist():
            if self.student_steps[i] == 0:
                self.finished["teacher"].append(float(self.returns[i]))
            elif self.teacher_steps[i] == 0:
                self.finished["student"].append(float(self.returns[i]))
        self.teacher_steps[dones] = 0
        self.student_steps[dones] = 0
        self.returns[dones] = 0

    # -- update --------------------------------------------------------------------------------------------
    def update(self) -> dict[str, float]:
        """Fit the student to the teacher's labels: ``mini_epochs`` passes over this rollout and the ones kept
        from the last ``dataset_epochs`` - 1 epochs (DAgger's aggregated dataset), minibatches of whole env
        rollouts."""
        cfg, model, b, comm = self.cfg, self.model, self.batch, self.ctx.comm
        # this rollout's statistics, as PPO (under torchrun the normalizer folds every rank's: built with comm)
        model.update_normalizers(obs=merge_steps(b["obs"]))
        self.dataset.append({k: b[k] for k in ("obs", "labels", "resets", "masks", "states")})
        data = _concat_envs(list(self.dataset))
        horizon, n = data["labels"].shape[:2]
        model.train()
        per = n // cfg.minibatches
        losses = []
        for _ in range(cfg.mini_epochs):
            order = torch.randperm(n, device=self.device)
            for k in range(cfg.minibatches):
                envs = order[k * per:(k + 1) * per]
                loss = self._minibatch_loss(data, envs, horizon)
                # multi_gpu: every rank steps with the ranks' mean gradient, as PPO
                step = self.agent.step(loss, cfg.grad_norm if cfg.truncate_grads else None,
                                       partial(loss_stats, loss), "the distillation update")
                losses.append(step["loss"])
        out = {"behavior_loss": comm.mean(float(np.mean(losses))), "teacher_action_prob": b["beta"],
               "lr": self.agent.lr, "action_match": b["match"]}
        for side in ("teacher", "student"):
            if self.finished[side]:
                out[f"{side}_return"] = float(np.mean(self.finished[side]))
        return out

    def _minibatch_loss(self, data: dict[str, Any], envs: torch.Tensor, horizon: int) -> torch.Tensor:
        """The behaviour loss on the whole rollouts of ``envs``: rows env by env (sequence-major for an RNN)."""
        model = self.model

        def rows(x: Any) -> Any:  # (T, N, ...) -> (n_envs * T, ...), env by env
            return env_rows(x, envs)

        states = tuple(s[:, envs] for s in data["states"]) if data["states"] else None
        masks = rows(data["masks"]) if data["masks"] is not None else None
        params, _, _ = model.evaluate(rows(data["obs"]), states, rows(data["resets"]), seq_length=horizon,
                                      action_masks=masks)
        return behavior_loss(model.dist, params, rows(data["labels"]), self.loss_kind, self.cfg.huber_delta).mean()

    def frames_per_epoch(self) -> int:
        """Env frames one epoch adds, over all ranks (torchrun)."""
        return self.cfg.horizon_length * self.num_envs * self.ctx.world_size

    # -- the rest of the protocol --------------------------------------------------------------------------
    def restart_episodes(self) -> None:
        """After a rollback: fresh episodes, zero RNN states."""
        super().restart_episodes()
        self.collector.place(self.collector.obs, self._initial_states())
        self.resets = torch.ones_like(self.resets)
        self.delay.line = None
        self.teacher_steps.zero_()
        self.student_steps.zero_()
        self.returns.zero_()

    def extra_state(self, kind: str) -> dict[str, Any]:
        """The teacher (weights and config, so the checkpoint stands alone) and the per-side returns."""
        return {"teacher": {"model": self.teacher.model.state_dict(), "path": self.teacher.path,
                            "config": config_state(self.teacher.params)},
                "distill": {side: list(v) for side, v in self.finished.items()}}

    def restore_extra(self, state: dict[str, Any]) -> None:
        """Restore the per-side returns (the teacher comes from teacher_checkpoint, as at the start)."""
        for side, values in state.get("distill", {}).items():
            self.finished[side].extend(values)
