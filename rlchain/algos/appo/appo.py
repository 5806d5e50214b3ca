"""APPO and IMPALA: an asynchronous learner fed by runners that wait for it only when its queue is full.

Runners (threads or Ray actors, :mod:`rlchain.algos.appo.runner_pool`) sample fixed-length fragments
with their own policy copy and queue them. One epoch of the learner (``collect`` then ``update``):

1. take fragments from the queue until it has ``num_actors`` envs' worth (``num_workers``
   fragments, from whichever runners are fastest); a fragment sampled more than
   ``appo.max_policy_lag`` policy versions ago is dropped and counted;
2. value the fragments with the current model (a recurrent one runs each env's fragment as one sequence from
   the RNN state its runner had there, :mod:`rlchain.algos.appo.learner_batch`) and compute V-trace targets and
   advantages (:func:`rlchain.algos.core.vtrace.vtrace`), fold them into the normalizers;
3. train with the PPO agent (``appo``: clipped surrogate of pi/mu on the V-trace advantages,
   ``mini_epochs`` passes, and with ``kl_loss_coef`` RLlib's KL penalty against a target policy;
   ``impala``: the V-trace policy gradient, one pass), adaptive lr included; a recurrent policy trains on
   ``seq_length`` sequences as PPO's does, each from the state its runner stored;
4. bump the policy version (every ``target_update_interval`` versions the KL penalty's target policy becomes a
   copy of the learner's); every ``appo.broadcast_interval`` versions publish the weights.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import time
from typing import Any, ClassVar

import torch

from rlchain.algos.appo.agents import APPOAgent, ImpalaAgent
from rlchain.algos.appo.fragments import Fragment
from rlchain.algos.appo.learner_batch import FragmentBatch, final_values, policy_pass
from rlchain.algos.appo.local_runners import LocalRunners
from rlchain.algos.appo.ray_runners import RayRunners
from rlchain.algos.appo.runner_pool import RunnerPool
from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard, check_rollout
from rlchain.algos.core.returns import shape_with
from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.core.vtrace import vtrace
from rlchain.config.actor_critic import check_batch
from rlchain.config.appo import APPOConfig, ImpalaConfig
from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.config.run import EnvRunnersConfig
from rlchain.envs.ray.ray_env import worker_slices
from rlchain.envs.ray.ray_worker import EnvRecipe
from rlchain.envs.spec import EnvSpec

PPO_TAGS = {"a_loss": "losses/a_loss", "c_loss": "losses/c_loss", "entropy": "losses/entropy",
            "b_loss": "losses/bounds_loss", "lr": "info/last_lr", "lr_mul": "info/lr_mul", "kl": "info/kl",
            "entropy_coef": "info/entropy_coef", "kl_coef": "info/kl_coef", "clip_frac": "info/clip_frac",
            "grad_norm": "info/grad_norm"}


class APPO(AlgorithmBase):
    """Algo ``appo`` (see the module docstring); ``impala`` is :class:`IMPALA`."""

    config_class: ClassVar[type] = APPOConfig
    agent_class: ClassVar[type] = APPOAgent
    metric_tags = {**PPO_TAGS, "policy_lag": "appo/policy_lag", "queue_size": "appo/queue_size",
                   "sample_throughput": "appo/sample_throughput", "dropped_fragments": "appo/dropped_fragments",
                   "learner_utilisation": "appo/learner_utilisation", "rho": "appo/mean_rho"}
    console_fields = (("kl", "kl {:.4f}"), ("lr", "lr {:.2e}"), ("policy_lag", "lag {:.1f}"),
                      ("queue_size", "queue {:.0f}"))
    tunable = ("learning_rate", "entropy_coef", "e_clip", "critic_coef", "bounds_loss_coef", "grad_norm",
               "kl_threshold", "mini_epochs", "gamma")
    supports_distributed = True  # multi_gpu: one learner and runner pool per rank, gradients averaged
    envs_idle_in_update = False  # the runners sample meanwhile: the update keeps the process's torch threads
    step_delays: ClassVar[list[float] | None] = None
    """Tests and benchmarks: a sleep per env step for each runner (stragglers); None: none."""

    @classmethod
    def check_config(cls, params: Params, spec: EnvSpec) -> None:
        """The minibatch must divide the learner batch."""
        check_batch(params.config, params.source, spec.num_agents)

    @classmethod
    def build_training_env(cls, params: Params, seed: int | None) -> RunnerPool:
        """The runners (local threads or Ray actors, ``appo.runners``) instead of a vectorized env."""

        cfg = params.config
        runners = cfg.env_runners if cfg.env_runners is not None else EnvRunnersConfig()
        try:
            slices = worker_slices(cfg.num_actors, runners)
        except ConfigError as exc:
            raise ConfigError(params.source, exc.path, exc.message) from None
        vecenv = None if cfg.vecenv_type is None or str(cfg.vecenv_type).lower() == "ray" else cfg.vecenv_type
        recipe = dataclasses.replace(EnvRecipe.capture(cfg.env_name, cfg.env_config, vecenv or "auto"),
                                     success_key=cfg.success_key, log_info_keys=tuple(cfg.log_info_keys))
        args = (recipe, slices, seed, cfg.horizon_length, cfg.appo.learner_queue_size, runners.max_restarts,
                cfg.appo.fragment_timeout_s, cls.step_delays)
        try:
            if runner_mode(cfg) == "ray":
                return RayRunners(*args, runners=runners)
            return LocalRunners(*args)
        except ImportError:
            raise ConfigError(params.source, "params.config.appo.runners", "ray runners need ray, which is not "
                              "installed: pip install rlchain[ray] (or appo.runners: local)") from None
        except ConfigError as exc:  # the Ray plumbing's errors name the key, not the file
            if exc.source:
                raise
            raise ConfigError(params.source, exc.path, exc.message) from None
        except ValueError as exc:
            raise ConfigError(params.source, "", str(exc)) from None

    def __init__(self, params: Params, env: RunnerPool, model: torch.nn.Module, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        cfg, device = self.cfg, self.device
        self.pool = env
        self.agent = self.agent_class(model, cfg, device, ctx.comm)
        self.divergence = DivergenceGuard(cfg.divergence, model, self.agent)
        self.version = 0  # learner updates so far: the policy version fragments are stamped with
        self.dropped_fragments = 0
        self.batch_fragments = env.num_workers
        self.batch: list[Fragment] = []
        self._received = 0  # frames received this epoch (dropped fragments included)
        self._epoch_frames = cfg.num_actors * cfg.horizon_length
        self._mark = time.monotonic()  # end of the previous update
        self._lags: list[int] = []
        obs_space = env.observation_space
        self.storage = RolloutStorage(
            cfg.horizon_length, cfg.num_actors, tuple(obs_space.shape),
            torch.uint8 if obs_space.dtype == "uint8" else torch.float32,
            model.dist.action_shape, model.dist.action_dtype, model.dist.param_size, env.value_size, device,
            state_shapes=tuple(tuple(s.shape) for s in model.initial_state(cfg.num_actors, device)))
        # APPO's KL penalty against a target policy refreshed every target_update_interval updates: a frozen copy
        # (an interval of 1 needs none: the target is the policy before each update)
        penalty = getattr(cfg, "kl_loss_coef", 0.0) > 0
        self.target = frozen_copy(model) if penalty and getattr(cfg, "target_update_interval", 1) > 1 else None

    # ----- the Algorithm hooks (rlchain.algos.base.algorithm) ------------------------------------
    def collect(self) -> bool:
        """Fragments from the queue until a learner batch is full; False when a stop signal came."""
        self.batch, self._lags, self._received = [], [], 0
        max_lag = self.cfg.appo.max_policy_lag
        while len(self.batch) < self.batch_fragments:
            if self.ctx.stop_requested():
                return False
            fragment = self.pool.get(timeout=0.2)
            if fragment is None:
                continue
            self._received += fragment.frames
            self.ctx.tracker.record(fragment.episode_returns, fragment.episode_lengths, fragment.episode_successes)
            if fragment.info_totals is not None:
                self.ctx.info_means.add_totals(*fragment.info_totals)
            lag = self.version - fragment.version
            if lag > max_lag:
                self.dropped_fragments += 1
                continue
            self.batch.append(fragment)
            self._lags.append(lag)
        return True

    def update(self) -> dict[str, float]:
        """V-trace on the batch, normalizers, the agent's update; a new policy version for the runners."""
        began = time.monotonic()
        self._fill_storage()
        self.model.train()
        stats = self.agent.update(self.storage, self.progress(self._received))
        stats["lr_mul"] = stats["lr"] / max(self.cfg.learning_rate, 1e-12)
        stats["rho"] = self._rho
        self.version += 1
        if self.target is not None and self.version % self.cfg.target_update_interval == 0:
            self.target.load_state_dict(self.model.state_dict())
        if self.version % self.cfg.appo.broadcast_interval == 0:
            self.pool.publish(self._weights(), self.version)
        received, ctx = self._received, self.ctx
        if ctx.comm.active:  # every rank counts every rank's frames, so all stop at the same max_frames
            received = round(ctx.comm.mean(float(received)) * ctx.world_size)
        self._epoch_frames = received  # what the Loop counts
        now = time.monotonic()
        stats.update(policy_lag=sum(self._lags) / max(len(self._lags), 1), queue_size=self.pool.queue_size(),
                     sample_throughput=self._received / max(now - self._mark, 1e-9),
                     dropped_fragments=self.dropped_fragments,
                     learner_utilisation=(now - began) / max(now - self._mark, 1e-9))
        self._mark = now
        return stats

    def frames_per_epoch(self) -> int:
        """Env frames the last epoch received (a learner batch plus any fragments dropped as stale)."""
        return self._epoch_frames

    # ----- the learner batch ----------------------------------------------------------------
    def _fill_storage(self) -> None:
        """Stack the fragments (envs side by side), value them, V-trace, normalizers; into the storage."""
        cfg, model, storage = self.cfg, self.model, self.storage
        t_len, n = cfg.horizon_length, cfg.num_actors
        batch = FragmentBatch.stack(self.batch, self.device)
        obs, actions, rewards, terminated = batch.obs, batch.actions, batch.rewards, batch.terminated
        check_rollout(rewards, obs[:t_len])
        dones = terminated | batch.truncated
        with torch.no_grad():
            model.eval()
            params, values = policy_pass(model, batch)
            pi_log_probs = model.dist.log_prob(params[:t_len].reshape(t_len * n, -1),
                                               actions.reshape(t_len * n, *actions.shape[2:]))
            next_values = values[1:].clone()
            ends = final_values(model, self.batch, self.device)
            if ends is not None:
                steps, envs, ends_values = ends
                next_values[steps, envs] = ends_values
            if rewards.dim() == 2:
                rewards = rewards.unsqueeze(-1)
            shaped = shape_with(rewards, cfg.reward_shaper)
            appo = cfg.appo
            out = vtrace(pi_log_probs.reshape(t_len, n) - batch.log_probs, shaped, values[:t_len], next_values,
                         terminated if cfg.value_bootstrap else dones, dones, cfg.gamma,
                         appo.vtrace_clip_rho, appo.vtrace_clip_c)
            flat = obs[:t_len].reshape(t_len * n, *obs.shape[2:])
            model.update_normalizers(obs=flat, returns=out.vs.reshape(-1, out.vs.shape[-1]),
                                     values=values[:t_len].reshape(-1, values.shape[-1]))
            storage.obs.copy_(obs[:t_len])
            storage.actions.copy_(actions)
            storage.log_probs.copy_(batch.log_probs)
            # the params the update's KL compares with: the learner's policy before this update (the adaptive
            # lr's KL: the lag behind the behaviour policy is not a step the lr should shrink for), or with
            # APPO's KL penalty the target policy's
            if self.target is not None:
                self.target.eval()
                params = policy_pass(self.target, batch)[0]
            storage.params.copy_(params[:t_len])
            for stored, state in zip(storage.states, batch.states):  # an RNN: the states entering every step
                stored.copy_(state[:t_len])
            if storage.resets is not None:
                storage.resets.copy_(batch.resets[:t_len])
            storage.values.copy_(values[:t_len])
            storage.returns.copy_(out.vs)
            storage.advantages.copy_(self.advantages(out))
            storage.written(t_len)
        self._rho = float(out.rhos.mean())

    def advantages(self, out: Any) -> torch.Tensor:
        """APPO: q - V (the surrogate weighs it by pi/mu itself)."""
        return out.advantages

    def _weights(self) -> dict[str, torch.Tensor]:
        """The model's parameters and normalizer statistics as CPU tensors, for the runners."""
        return {k: v.detach().to("cpu", copy=True) for k, v in self.model.state_dict().items()}

    # ----- the runners -------------------------------------------------------------------------
    def start(self) -> None:
        """Start the runners with the current weights (the first time); they reset their own envs."""
        if not self.pool.started:
            self.pool.start(self.model, self._weights(), self.version)
            self._mark = time.monotonic()

    def restart_episodes(self) -> None:
        """After a rollback: drop the queued fragments of the diverged policy, publish the restored one."""
        self.dropped_fragments += self.pool.drain()
        self.version += self.cfg.appo.max_policy_lag + 1  # what is in flight is now too old
        self.pool.publish(self._weights(), self.version)

    # ----- checkpoints ----------------------------------------------------------------------
    def extra_state(self, kind: str) -> dict[str, Any]:
        out = {"policy_version": self.version, "dropped_fragments": self.dropped_fragments}
        if self.target is not None:
            out["kl_target_policy"] = self.target.state_dict()
        return out

    def restore_extra(self, state: dict[str, Any]) -> None:
        self.version = int(state.get("policy_version", 0))
        self.dropped_fragments = int(state.get("dropped_fragments", 0))
        if self.target is not None:  # a checkpoint saved without a target: the restored policy is the target
            self.target.load_state_dict(state.get("kl_target_policy", self.model.state_dict()))


class IMPALA(APPO):
    """Algo ``impala``: the V-trace actor-critic, one pass per batch, no surrogate clipping."""

    config_class = ImpalaConfig
    agent_class = ImpalaAgent
    tunable = ("learning_rate", "entropy_coef", "critic_coef", "bounds_loss_coef", "grad_norm", "kl_threshold",
               "gamma")

    def advantages(self, out: Any) -> torch.Tensor:
        """min(rho-bar, pi/mu) * (q - V): IMPALA's policy-gradient advantage."""
        return out.pg_advantages


def frozen_copy(model: torch.nn.Module) -> torch.nn.Module:
    """A copy of ``model`` that takes no gradient (a target policy)."""
    target = copy.deepcopy(model)
    for p in target.parameters():
        p.requires_grad_(False)
    return target


def runner_mode(cfg: APPOConfig) -> str:
    """``appo.runners`` resolved: auto is ray when a cluster address is given, else local."""
    mode = cfg.appo.runners
    if mode == "auto":
        address = cfg.env_runners.address if cfg.env_runners is not None else None
        mode = "ray" if address or os.environ.get("RAY_ADDRESS") else "local"
    return mode
