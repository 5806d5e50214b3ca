"""The off-policy loop (SAC, DQN): act -> replay buffer -> updates -> log -> checkpoint, until a stop.

One epoch is ``num_steps_per_episode`` vectorized env steps (``num_actors * num_steps_per_episode``
frames). The first ``num_warmup_frames`` frames act uniformly at random and do not learn; after
that every env step is followed by ``num_updates_per_step`` gradient updates on replay minibatches.
Episode bookkeeping, logging tags, checkpoints, stop signals, callbacks and evaluation are the
on-policy trainer's pieces.
"""

from __future__ import annotations

import math
import time
from typing import Any

import torch

from rlchain.algos.dqn import DQNAgent, epsilon_at
from rlchain.algos.replay import ReplayBuffer
from rlchain.algos.returns import shape_rewards
from rlchain.algos.sac import SACAgent
from rlchain.config.off_policy import DQNConfig, SACConfig
from rlchain.config.schema import Params
from rlchain.errors import DivergenceError, EnvError
from rlchain.training.base import TrainerBase, TrainResult, describe
from rlchain.training.logging import TrainLogger
from rlchain.training.run_dir import RunDir
from rlchain.training.safety import DivergenceGuard, StopSignals, check_parameters


class OffPolicyTrainer(TrainerBase):
    """Coordinates env, model, agent (SAC/DQN update), replay buffer, logger and checkpoints."""

    config_class: type = SACConfig
    loss_tags: dict[str, str] = {}

    def __init__(self, params: Params, env: Any, model: torch.nn.Module, device: torch.device,
                 run: RunDir | None, logger: TrainLogger, seed: int, raw_config: dict) -> None:
        super().__init__(params, env, model, device, run, logger, seed, raw_config)
        cfg = self.cfg
        self.agent = self.make_agent()
        obs_space = env.observation_space
        self.buffer = ReplayBuffer(
            cfg.replay_buffer_size, tuple(obs_space.shape), tuple(model.dist.action_shape), device,
            num_envs=self.num_envs, obs_dtype=torch.uint8 if obs_space.dtype == "uint8" else torch.float32,
            action_dtype=model.dist.action_dtype, n_step=cfg.n_step, gamma=cfg.gamma,
            prioritized=cfg.prioritized_replay, alpha=cfg.priority_alpha, beta=cfg.priority_beta)
        self.divergence = DivergenceGuard(cfg.divergence, model, self.agent)

    def make_agent(self) -> Any:  # pragma: no cover - subclasses
        raise NotImplementedError

    # ----- the loop -------------------------------------------------------------------------
    def train(self) -> TrainResult:
        """Train until max_epochs, max_frames, score_to_win or a stop signal; returns the statistics."""
        start = time.time()
        stop = None
        with StopSignals() as signals:
            self.signals = signals
            self.obs = self._reset_envs()
            self.divergence.snapshot(self.epoch)
            self.events.emit("on_train_start", self)
            while stop is None:
                t0 = time.time()
                try:
                    stats, update_s, completed = self._guarded_epoch()
                    bad = check_parameters(self.model)
                    if bad is not None:
                        raise DivergenceError(f"{bad} became non-finite in the update")
                except DivergenceError as exc:
                    self._diverged(exc)
                    continue  # rolled back: go on from the snapshot with a lower learning rate
                if not completed:
                    stop = f"interrupted by {signals.requested}"
                    break
                self.events.emit("on_rollout_end", self)
                self.epoch += 1
                if self.epoch % self.cfg.snapshot_epochs == 0:
                    self.divergence.snapshot(self.epoch)
                episodes = self._episode_stats()
                self._log(stats, episodes, time.time() - t0 - update_s, update_s)
                self._checkpoints(episodes)
                self.events.emit("on_epoch_end", self, stats, episodes)
                stop = self._stop_reason(episodes)
            last = self.save("last")
        return self._finish(stop, start, last)

    def _diverged(self, exc: DivergenceError) -> None:
        """A NaN/inf: roll back to the last snapshot and restart the envs' episodes (``divergence.action:
        rollback``, within max_rollbacks), else save what is finite and raise naming the epoch."""
        try:
            self.divergence.handle(exc, self.epoch)
        except DivergenceError:
            self.save("last")  # refused while the parameters are non-finite
            raise
        self.tracker.reset_running()
        self.obs = self._reset_envs()

    def _reset_envs(self) -> torch.Tensor:
        obs = super()._reset_envs()
        self.model.update_normalizers(obs=obs)
        return obs

    def _guarded_epoch(self) -> tuple[dict[str, float], float, bool]:
        try:
            return self._epoch()
        except (EnvError, DivergenceError, KeyboardInterrupt):
            raise
        except Exception as exc:
            path = self.save("last")
            saved = f"; last completed epoch {self.epoch} saved to {path}" if path else ""
            raise EnvError(f"env step failed at epoch {self.epoch + 1}: {describe(exc)}{saved}") from exc

    def _epoch(self) -> tuple[dict[str, float], float, bool]:
        """num_steps_per_episode env steps, each followed by updates once warmup is over."""
        cfg, model, dist = self.cfg, self.model, self.model.dist
        rs = cfg.reward_shaper
        sums: dict[str, torch.Tensor] = {}
        count = 0
        update_s = 0.0
        obs = self.obs
        for _ in range(cfg.num_steps_per_episode):
            if self.signals is not None and self.signals.requested:
                return {}, update_s, False
            model.eval()
            if self.frames < cfg.num_warmup_frames:
                actions = dist.random(self.num_envs, self.device)
            else:
                actions = self.explore(obs)
            result = self.env.step(self._env_actions(dist.to_env(actions)))
            rewards, terminated, truncated, dones = self._env_outcome(result)
            if rewards.dim() > 1:
                rewards = rewards.sum(-1)
            shaped = shape_rewards(rewards, rs.scale_value, rs.shift_value, rs.min_val, rs.max_val, rs.log_val)
            next_obs = self._to_tensor(result.obs)
            if not bool(torch.isfinite(shaped).all()) or (next_obs.is_floating_point()
                                                          and not bool(torch.isfinite(next_obs).all())):
                raise DivergenceError("the env returned a non-finite reward or observation")
            real_next = next_obs
            if bool(dones.any()):
                real_next = next_obs.clone()
                rows = dones.nonzero().squeeze(-1)
                real_next[rows] = self._to_tensor(result.final_obs)[rows].to(next_obs.dtype)
            self.buffer.add(obs, actions, shaped, real_next, terminated, truncated)
            model.update_normalizers(obs=next_obs)
            obs = next_obs
            self.frames += self.num_envs
            if self.frames >= cfg.num_warmup_frames and len(self.buffer) >= cfg.batch_size:
                t0 = time.time()
                model.train()
                with self.update_phase():
                    for _ in range(cfg.num_updates_per_step):
                        batch = self.buffer.sample(cfg.batch_size, beta=self._beta())
                        stats, td = self.agent.update(batch)
                        self.buffer.update_priorities(batch["indices"], td)
                        for k, v in stats.items():
                            sums[k] = sums.get(k, 0.0) + v
                        count += 1
                update_s += time.time() - t0
        self.obs = obs
        out = {k: float(v) / count for k, v in sums.items()} if count else {}
        out["updates"] = count
        return out, update_s, True

    def explore(self, obs: torch.Tensor) -> torch.Tensor:
        return self.model.act(obs)["actions"]

    def _beta(self) -> float:
        """Importance-sampling exponent, annealed from priority_beta to 1 over the run."""
        cfg = self.cfg
        progress = 0.0
        if cfg.max_frames > 0:
            progress = self.frames / cfg.max_frames
        elif cfg.max_epochs > 0:
            progress = self.epoch / cfg.max_epochs
        return cfg.priority_beta + min(progress, 1.0) * (1.0 - cfg.priority_beta)

    # ----- bookkeeping ----------------------------------------------------------------------
    def extra_stats(self) -> dict[str, float]:
        return {}

    def _log(self, stats: dict[str, float], episodes: dict | None, rollout_s: float, update_s: float) -> None:
        """rl_games' tag names where the quantity is the same as PPO's, plus losses/* of this algorithm."""
        s, frames, epoch = self.logger.scalar, self.frames, self.epoch
        batch = self.cfg.num_steps_per_episode * self.num_envs
        elapsed = int(time.time() - self.logger.start)
        step_fps = batch / max(rollout_s, 1e-9)
        total_fps = batch / max(rollout_s + update_s, 1e-9)
        s("performance/step_fps", step_fps, frames)
        s("performance/step_inference_rl_update_fps", total_fps, frames)
        s("performance/rl_update_time", update_s, frames)
        s("performance/step_time", rollout_s, frames)
        s("info/last_lr", self.agent.lr, frames)
        s("info/epochs", epoch, frames)
        s("info/updates", self.agent.updates, frames)
        s("info/replay_size", len(self.buffer), frames)
        extra = self.extra_stats()
        for key, value in extra.items():
            s(f"info/{key}", value, frames)
        for key, tag in self.loss_tags.items():
            if key in stats:
                s(tag, stats[key], frames)
        if episodes is not None:
            for name, value in (("rewards", episodes["reward"]), ("episode_lengths", episodes["length"])):
                s(f"{name}/step", value, frames)
                s(f"{name}/iter", value, epoch)
                s(f"{name}/time", value, elapsed)
        if self.cfg.print_stats:
            limit = f"/{self.cfg.max_epochs}" if self.cfg.max_epochs > 0 else ""
            reward = f"{episodes['reward']:.2f}" if episodes is not None else "-"
            length = f"{episodes['length']:.1f}" if episodes is not None else "-"
            best_text = f"{self.best_reward:.2f}" if math.isfinite(self.best_reward) else "-"
            shown = {k: stats[k] for k in self.loss_tags if k in stats}
            shown.update(extra)
            losses = " | ".join(f"{k} {v:.3g}" for k, v in shown.items())
            print(f"epoch {epoch}{limit} | frames {frames} | fps {total_fps:.0f} (step {step_fps:.0f}) | "
                  f"reward {reward} | best {best_text} | len {length}{' | ' + losses if losses else ''} | "
                  f"{elapsed}s", file=self.logger.stream, flush=True)

    # ----- checkpoints ----------------------------------------------------------------------
    def extra_state(self, kind: str) -> dict[str, Any]:
        """The replay buffer, only with save_replay_buffer and only in last checkpoints."""
        if self.cfg.save_replay_buffer and kind == "last":
            return {"replay_buffer": self.buffer.state_dict()}
        return {}

    def restore_extra(self, state: dict[str, Any]) -> None:
        if "replay_buffer" in state:  # else the empty buffer refills to batch_size before learning resumes
            self.buffer.load_state_dict(state["replay_buffer"])


class SACTrainer(OffPolicyTrainer):
    """Algo ``sac``."""

    config_class = SACConfig
    loss_tags = {"actor_loss": "losses/actor_loss", "critic_loss": "losses/critic_loss",
                 "alpha_loss": "losses/alpha_loss", "entropy": "losses/entropy", "q": "info/q"}

    def make_agent(self) -> SACAgent:
        return SACAgent(self.model, self.cfg)

    def extra_stats(self) -> dict[str, float]:
        return {"alpha": float(self.model.alpha.detach())}


class DQNTrainer(OffPolicyTrainer):
    """Algo ``dqn``."""

    config_class = DQNConfig
    loss_tags = {"td_loss": "losses/td_loss", "q": "info/q"}

    def make_agent(self) -> DQNAgent:
        return DQNAgent(self.model, self.cfg)

    def epsilon(self) -> float:
        cfg = self.cfg
        return epsilon_at(self.frames - cfg.num_warmup_frames, cfg.epsilon_start, cfg.epsilon_end,
                          cfg.epsilon_decay_frames)

    def explore(self, obs: torch.Tensor) -> torch.Tensor:
        return self.model.act(obs, epsilon=self.epsilon())["actions"]

    def extra_stats(self) -> dict[str, float]:
        return {"epsilon": self.epsilon()}
