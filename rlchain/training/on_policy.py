"""The on-policy loop: rollout -> returns -> update -> log -> checkpoint, until a stop condition."""

from __future__ import annotations

import threading
import time
from typing import Any

import torch

from rlchain.algos.central_value import CentralValueAgent
from rlchain.algos.ppo import PPOAgent
from rlchain.algos.returns import gae, next_values_from_rollout
from rlchain.algos.storage import RolloutStorage
from rlchain.config.errors import ConfigError
from rlchain.config.schema import Params
from rlchain.errors import DivergenceError, EnvError
from rlchain.models.actor_critic import ActorCritic
from rlchain.training import checkpoint as ckpt
from rlchain.training.base import TrainerBase, TrainResult, describe
from rlchain.training.build import build_central_value
from rlchain.training.compile import compile_model
from rlchain.training.logging import TrainLogger
from rlchain.training.rollout import RolloutMixin
from rlchain.training.run_dir import RunDir
from rlchain.training.safety import (
    DivergenceGuard,
    StopSignals,
    check_parameters,
    check_rollout,
)


class OnPolicyTrainer(RolloutMixin, TrainerBase):
    """Coordinates env, model, PPO agent, storage, logger and checkpoints."""

    def __init__(self, params: Params, env: Any, model: ActorCritic, device: torch.device,
                 run: RunDir | None, logger: TrainLogger, seed: int, raw_config: dict) -> None:
        super().__init__(params, env, model, device, run, logger, seed, raw_config)
        cfg = self.cfg
        compile_model(model, cfg.torch_compile)
        self.agent = PPOAgent(model, cfg, device)
        self.central_value = build_central_value(params, env, device)
        self.cv_agent = None
        if self.central_value is not None:  # the asymmetric critic replaces the actor's value head
            self.cv_agent = CentralValueAgent(self.central_value, cfg.central_value_config, device)
            self.agent.train_critic = False
        obs_space = env.observation_space
        self.use_masks = _check_action_masks(cfg.use_action_masks, env, params.source)
        # RNN states carried through the rollout: the model's, then the central value's
        self.rnn_states = self._initial_states()
        self.resets = torch.ones(self.num_envs, dtype=torch.bool, device=device)
        self.storage = RolloutStorage(
            cfg.horizon_length, self.num_envs, tuple(obs_space.shape),
            torch.uint8 if obs_space.dtype == "uint8" else torch.float32,
            model.dist.action_shape, model.dist.action_dtype, model.dist.param_size,
            _value_size(env), device, mask_size=model.dist.param_size if self.use_masks else 0,
            state_shapes=tuple(tuple(s.shape) for s in self.rnn_states))
        self.divergence = DivergenceGuard(cfg.divergence, model, self.agent)
        self._params_lock = threading.Lock()
        self._pending_params: dict[str, float] = {}

    # ----- the loop -------------------------------------------------------------------------
    def train(self) -> TrainResult:
        """Train until max_epochs, max_frames, score_to_win or a stop signal; returns the statistics.

        SIGINT/SIGTERM stop after the current env step with a checkpoint of the last completed
        epoch; an env failure does the same, then raises EnvError; a NaN/inf stops (or rolls back,
        with ``divergence.action: rollback``) without ever saving non-finite parameters.
        """
        start = time.time()
        stop = None
        with StopSignals() as signals:
            self.signals = signals
            self.obs = self._reset_envs()
            self.divergence.snapshot()
            self.events.emit("on_train_start", self)
            while stop is None:
                self._apply_pending_params()
                t0 = time.time()
                if not self._guarded_rollout():
                    stop = f"interrupted by {signals.requested}"
                    break
                self.events.emit("on_rollout_end", self)
                t1 = time.time()
                stats = self._guarded_learn()
                if stats is None:
                    continue  # rolled back: collect a fresh rollout with the restored policy
                t2 = time.time()
                self.epoch += 1
                self.frames += self._frames_per_epoch()
                episodes = self._episode_stats()
                self._log(stats, episodes, t1 - t0, t2 - t1)
                self._checkpoints(episodes)
                self.divergence.snapshot()
                self.events.emit("on_epoch_end", self, stats, episodes)
                stop = self._stop_reason(episodes)
            last = self.save("last")
        return self._finish(stop, start, last)

    TUNABLE = ("learning_rate", "entropy_coef", "e_clip", "critic_coef", "bounds_loss_coef", "grad_norm",
               "kl_threshold", "mini_epochs", "gamma", "tau")

    def get_params(self) -> dict[str, float]:
        """The training parameters population-based training may change (see :meth:`set_params`)."""
        values = {name: getattr(self.cfg, name) for name in self.TUNABLE}
        values["learning_rate"] = self.agent.lr
        values["entropy_coef"] = self.agent.entropy_coef  # live: set_params and schedule_entropy change it
        values["entropy_coef"] = self.agent.entropy_coef
        return values

    def set_params(self, **changes: float) -> None:
        """Change training parameters; they apply from the next epoch (thread-safe) and are logged."""
        unknown = [k for k in changes if k not in self.TUNABLE]
        if unknown:
            raise KeyError(f"cannot set {unknown[0]}; settable: {', '.join(self.TUNABLE)}")
        with self._params_lock:
            self._pending_params.update(changes)

    def _apply_pending_params(self) -> None:
        with self._params_lock:
            changes, self._pending_params = self._pending_params, {}
        for name, value in changes.items():
            if name == "learning_rate":
                self.agent._set_lr(float(value))
            elif name == "entropy_coef":  # the live value; schedule_entropy sets it again after the epoch
                self.agent.entropy_coef = float(value)
            else:
                setattr(self.cfg, name, type(getattr(self.cfg, name) or 0.0)(value))
            self.logger.scalar(f"params/{name}", float(value), self.frames)
            print(f"set {name} = {value} at epoch {self.epoch}", flush=True)
        if "kl_threshold" in changes and hasattr(self.agent.schedule, "kl_threshold"):
            self.agent.schedule.kl_threshold = float(changes["kl_threshold"])

    def _guarded_rollout(self) -> bool:
        """A rollout; False when a stop signal arrived. An env failure saves, then raises EnvError."""
        try:
            return self._rollout()
        except (EnvError, DivergenceError):
            self.save("last")
            raise
        except KeyboardInterrupt:
            raise
        except Exception as exc:
            path = self.save("last")
            saved = f"; last completed epoch {self.epoch} saved to {path}" if path else ""
            raise EnvError(f"env step failed at epoch {self.epoch + 1}: {describe(exc)}{saved}") from exc

    def _guarded_learn(self) -> dict[str, float] | None:
        """The update; on NaN/inf either roll back (returns None) or raise with the epoch named."""
        try:
            bad = check_rollout(self.storage.rewards, self.storage.obs)
            if bad is not None:
                raise DivergenceError(bad)
            with self.update_phase():
                stats = self._learn()
            bad = check_parameters(self.model)
            if bad is not None:
                raise DivergenceError(f"{bad} became non-finite in the update")
            return stats
        except DivergenceError as exc:
            self.divergence.handle(exc, self.epoch)  # raises unless it rolled back
            self.tracker.reset_running()
            self.obs = self._reset_envs()
            self._reset_states()
            return None

    def _initial_states(self) -> tuple[torch.Tensor, ...]:
        states = tuple(self.model.initial_state(self.num_envs, self.device))
        if self.central_value is not None:
            states += self.central_value.initial_state(self.num_envs, self.device)
        return states

    def _reset_states(self) -> None:
        """Fresh episodes everywhere: zero RNN states, every row starts an episode."""
        self.rnn_states = self._initial_states()
        self.resets.fill_(True)

    def _learn(self) -> dict[str, float]:
        """GAE on the rollout, normalizer updates, then the PPO update.

        Every normalizer folds this rollout in before the update, so the network is trained with the
        statistics the next rollout acts with. (Folding the observations in after the update, as
        rlchain did before, trained each update under one normalization and acted under another:
        Hopper reached ~400 at 0.5M frames against ~1,450 this way; docs/ppo_parity.md.)
        """
        cfg, storage, model = self.cfg, self.storage, self.model
        flat_obs = storage.obs.reshape(-1, *storage.obs.shape[2:])
        with torch.no_grad():
            next_values = next_values_from_rollout(storage.values, self.last_values,
                                                   storage.final_values, storage.dones)
            adv, returns = gae(storage.rewards, storage.values, next_values, storage.terminated,
                               storage.dones, cfg.gamma, cfg.tau)
            storage.advantages.copy_(adv)
            storage.returns.copy_(returns)
            storage.final_values.zero_()
            flat_returns = returns.reshape(-1, returns.shape[-1])
            model.update_normalizers(obs=flat_obs, returns=flat_returns)
            if self.central_value is not None:
                self.central_value.update_normalizers(obs=flat_obs, returns=flat_returns)
        model.train()
        stats = self.agent.update(storage, self._progress())
        stats["lr0"] = cfg.learning_rate
        if self.cv_agent is not None:
            stats.update(self.cv_agent.update(storage, self._progress(), model.num_states, cfg.seq_length,
                                              cfg.zero_rnn_on_done))
        return stats

    def extra_state(self, kind: str) -> dict:
        """The central value's weights and optimizer, when there is one."""
        if self.central_value is None:
            return {}
        return {"central_value": self.central_value.state_dict(), "central_value_agent": self.cv_agent.state_dict()}

    def restore_extra(self, state: dict) -> None:
        if self.central_value is None:
            return
        if "central_value" not in state:
            raise ckpt.CheckpointError("checkpoint has no central value network; it was trained without "
                                       "central_value_config")
        self.central_value.load_state_dict(state["central_value"])
        self.cv_agent.load_state_dict(state["central_value_agent"])

    # ----- bookkeeping ----------------------------------------------------------------------
    def _log(self, stats: dict, episodes: dict | None, rollout_s: float, update_s: float) -> None:
        timing = {"batch": self._frames_per_epoch(), "rollout": rollout_s,
                  "update": update_s}
        self.logger.epoch(self.epoch, self.cfg.max_epochs, self.frames, stats, episodes,
                          self.best_reward, timing)

    def _frames_per_epoch(self) -> int:
        """Env steps per epoch over all ranks, as rl_games counts them: agents of one env share a step."""
        return self.cfg.horizon_length * (self.num_envs // self.num_agents) * self.world_size

    def _progress(self) -> float:
        cfg = self.cfg
        if cfg.max_epochs > 0:
            return (self.epoch + 1) / cfg.max_epochs
        if cfg.max_frames > 0:
            return (self.frames + self._frames_per_epoch()) / cfg.max_frames
        return 0.0

def _check_action_masks(use_action_masks: bool, env: Any, source: str) -> bool:
    """With use_action_masks the env must provide masks; a one-line ConfigError otherwise."""
    if not use_action_masks:
        return False
    has = getattr(env, "has_action_mask", None)
    if not callable(has) or not has():
        raise ConfigError(source, "params.config.use_action_masks",
                          "True, but the env has no action masks (has_action_mask() / get_action_mask())")
    return True


def _value_size(env: Any) -> int:
    return int(getattr(env, "value_size", 1))
