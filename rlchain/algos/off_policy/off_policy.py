"""Off-policy algorithms (SAC, DQN): act -> replay buffer -> updates, every env step.

One epoch is ``num_steps_per_episode`` vectorized env steps (``num_actors * num_steps_per_episode``
frames). The first ``num_warmup_frames`` frames act uniformly at random and do not learn; after
that every ``update_every``-th vectorized env step (default: each) is followed by ``num_updates_per_step``
gradient updates on replay minibatches.
Episode bookkeeping, logging, checkpoints, stop signals, divergence handling, callbacks and
evaluation are the Loop's (rlchain.training.loop, which holds the algorithm), as for PPO.
"""

from __future__ import annotations

import time
from typing import Any

import gymnasium as gym
import torch

from rlchain.algos.base.algorithm import AlgorithmBase, position_copy, position_on
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import DivergenceGuard
from rlchain.algos.core.replay import ReplayBuffer
from rlchain.algos.core.returns import shape_with
from rlchain.algos.core.schedules import set_lr
from rlchain.algos.core.stepper import OffPolicyStepper
from rlchain.algos.off_policy.her import HERReplayBuffer, goal_layout
from rlchain.config.errors import ConfigError
from rlchain.config.off_policy import SACConfig
from rlchain.config.params import Params
from rlchain.envs.obs_dict import is_dict_space, obs_row_bytes
from rlchain.envs.vecenv import VecEnv
from rlchain.envs.wrappers.goal_env import env_compute_reward
from rlchain.log import get_logger
from rlchain.parallel.memory import check_fits

log = get_logger(__name__)


class UpdatesInCollect:
    """The epoch of an algorithm whose gradient updates run inside ``collect()`` between env steps (off-policy, one or
    several policies): ``num_steps_per_episode`` env steps of every env, the updates' seconds (``_update_s``, set by
    ``collect()``) moved to the update column, a learner snapshot every ``snapshot_epochs`` epochs."""

    cfg: Any
    ctx: RunContext
    num_envs: int
    _update_s: float

    def frames_per_epoch(self) -> int:
        return self.cfg.num_steps_per_episode * self.num_envs

    def epoch_seconds(self, collect_s: float, update_s: float) -> tuple[float, float]:
        """The gradient updates ran inside collect: their time moves to the update column."""
        return collect_s - self._update_s, self._update_s + update_s

    def snapshot_due(self) -> bool:
        """An in-memory learner copy every ``snapshot_epochs`` epochs (epochs are short off-policy)."""
        return self.ctx.epoch % self.cfg.snapshot_epochs == 0


class OffPolicyAlgorithm(UpdatesInCollect, AlgorithmBase):
    """An off-policy algorithm: env steps into a replay buffer, updates from it."""

    config_class: type = SACConfig
    SHARED_TAGS = {"lr": "info/last_lr", "total_updates": "info/updates", "replay_size": "info/replay_size"}
    counts_frames_while_collecting = True  # the stepper counts each env step (warmup and epsilon read ctx.frames)

    def __init__(self, params: Params, env: VecEnv, model: torch.nn.Module, ctx: RunContext) -> None:
        super().__init__(params, env, model, ctx)
        cfg = self.cfg
        self.agent = self.make_agent()
        self.buffer = self.make_buffer()
        self.stepper = OffPolicyStepper(env, model, ctx, cfg, self.buffer)
        self.obs: Any = None  # where the envs stand: the observations the next step acts on (the stepper keeps none)
        self.divergence = DivergenceGuard(cfg.divergence, model, self.agent)
        self._epoch_stats: dict[str, float] = {}
        self._update_s = 0.0  # seconds of gradient updates inside the last collect()
        self._replay_size_said = False

    @classmethod
    def check_config(cls, params: Params, spec: Any) -> None:
        """The replay buffer must fit the training device's free memory (checked before it is built)."""
        cfg, obs_space = params.config, spec.observation_space
        if obs_space is None or spec.action_space is None:
            return
        obs = obs_row_bytes(obs_space)
        per = 2 * obs + 4 * gym.spaces.flatdim(spec.action_space) + 11  # obs, next obs, action; reward .. flags
        check_fits(cfg.replay_buffer_size * per, cfg.device, params.source, "params.config.replay_buffer_size",
                   f"the replay buffer ({cfg.replay_buffer_size} transitions)")

    def make_agent(self) -> Any:  # pragma: no cover - subclasses
        raise NotImplementedError

    def make_buffer(self) -> ReplayBuffer:
        """The replay buffer the config asks for: uniform / prioritized / n-step, or with hindsight goals."""
        cfg, obs_space = self.cfg, self.env.observation_space
        per_key = is_dict_space(obs_space)  # Dict observations kept per key: a buffer per key, in its dtype
        args = (cfg.replay_buffer_size, obs_space if per_key else tuple(obs_space.shape),
                tuple(self.model.dist.action_shape))
        kwargs = dict(device=self.device, num_envs=self.num_envs,
                      obs_dtype=torch.uint8 if not per_key and obs_space.dtype == "uint8" else torch.float32,
                      action_dtype=self.model.dist.action_dtype, n_step=cfg.n_step, n_step_max=cfg.n_step_max,
                      gamma=cfg.gamma,
                      prioritized=cfg.prioritized_replay, alpha=cfg.priority_alpha, beta=cfg.priority_beta)
        her = cfg.replay.her
        if her is None:
            return ReplayBuffer(*args, **kwargs)
        if per_key:
            raise ConfigError(self.params.source, "params.config.replay.her", "hindsight replay relabels the flat "
                              "observation: use a network that takes it flat (not multi_input) with a goal env")
        try:
            layout = goal_layout(obs_space)
            reward_fn = goal_reward_fn(env_compute_reward(self.env), cfg.reward_shaper, self.device)
        except ValueError as exc:
            raise ConfigError(self.params.source, "params.config.replay.her", str(exc)) from None
        return HERReplayBuffer(*args, layout, reward_fn, strategy=her.strategy, k=her.k, **kwargs)

    # ----- the Algorithm hooks (rlchain.algos.base.algorithm) ------------------------------------
    def collect(self) -> bool:
        """num_steps_per_episode env steps, each followed by updates once warmup is over (the
        updates run here, between the steps; :meth:`update` reports them). A stop signal (Ctrl-C,
        SIGTERM) ends the run after this epoch, not inside it: the learner changes during the epoch,
        so only a whole epoch checkpoints exactly (off-policy epochs are a few env steps)."""
        self._epoch_stats, self._update_s, completed = self._epoch()
        return completed

    def update(self) -> dict[str, float]:
        """The epoch's mean losses (its updates ran during :meth:`collect`), lr and buffer size."""
        stats = dict(self._epoch_stats)
        stats.update(lr=self.agent.lr, total_updates=self.agent.updates, replay_size=len(self.buffer))
        stats.update(self.extra_stats())
        return stats

    def apply_hyperparam(self, name: str, value: float) -> None:
        """Learning rates go to their optimizer; gamma to the replay buffer's n-step returns too."""
        optimizers = self.agent.optimizers()
        if name in optimizers:
            set_lr(optimizers[name], value)
            return
        super().apply_hyperparam(name, value)
        if name == "gamma":
            self.buffer.gamma = float(value)

    def hyperparams(self) -> dict[str, float]:
        """The tunable values; learning rates are the optimizers' live ones (rollbacks lower them)."""
        values = super().hyperparams()
        for name, opt in self.agent.optimizers().items():
            values[name] = opt.param_groups[0]["lr"]
        return values

    def start(self) -> None:
        """Reset the envs; their first observations go into the normalizers (a resume that restores the
        envs' state continues from the checkpoint's observations instead: the normalizers have them)."""
        if self.resume_position():
            return
        self.obs = self.ctx.reset_envs()
        self.model.update_normalizers(obs=self.obs)

    def position_state(self) -> dict[str, Any] | None:
        """The observations the next env step acts on (a copy); None before ``start``."""
        return None if self.obs is None else {"obs": position_copy(self.obs)}

    def load_position(self, position: dict[str, Any]) -> None:
        """Put back :meth:`position_state` on the training device (Dict observations per key)."""
        self.obs = position_on(position["obs"], self.device)

    def restart_episodes(self) -> None:
        """After a rollback: fresh episodes everywhere."""
        self.ctx.tracker.reset_running()
        self.obs = self.ctx.reset_envs()
        self.model.update_normalizers(obs=self.obs)

    def _epoch(self) -> tuple[dict[str, float], float, bool]:
        """num_steps_per_episode env steps, each followed by updates once warmup is over."""
        cfg, model, dist, ctx = self.cfg, self.model, self.model.dist, self.ctx
        sums: dict[str, torch.Tensor] = {}
        count = 0
        update_s = 0.0
        obs = self.obs
        for _ in range(cfg.num_steps_per_episode):  # a stop signal waits for the epoch's end (see collect)
            model.eval()
            if ctx.frames < cfg.num_warmup_frames:
                actions = dist.random(self.num_envs, self.device)
            else:
                actions = self.explore(obs)
            obs = self.stepper.step(obs, actions)
            # the run's vectorized steps so far (the stepper counts frames per step) pick the update rounds, so a
            # resumed run keeps them
            round_due = cfg.update_every == 1 or (ctx.frames // self.num_envs) % cfg.update_every == 0
            if round_due and ctx.frames >= cfg.num_warmup_frames and len(self.buffer) >= cfg.batch_size:
                t0 = time.time()
                model.train()
                with ctx.update_phase():
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
        cfg, ctx = self.cfg, self.ctx
        progress = 0.0
        if cfg.max_frames > 0:
            progress = ctx.frames / cfg.max_frames
        elif cfg.max_epochs > 0:
            progress = ctx.epoch / cfg.max_epochs
        return cfg.priority_beta + min(progress, 1.0) * (1.0 - cfg.priority_beta)

    # ----- bookkeeping ----------------------------------------------------------------------
    def extra_stats(self) -> dict[str, float]:
        """Per-epoch values of the algorithm beyond its losses (SAC: alpha, DQN: epsilon)."""
        return {}

    # ----- checkpoints ----------------------------------------------------------------------
    def extra_state(self, kind: str) -> dict[str, Any]:
        """The replay buffer's contents, in every checkpoint, with save_replay_buffer (its size is said
        once, at the first checkpoint)."""
        if not self.cfg.save_replay_buffer:
            return {}
        state = self.buffer.state_dict()
        if not self._replay_size_said:
            self._replay_size_said = True
            size = replay_bytes(state)
            full = size * self.buffer.capacity / max(len(self.buffer), 1)
            log.info(f"save_replay_buffer: checkpoints carry the replay buffer, {len(self.buffer)} transitions "
                     f"now ({human_bytes(size)}; {human_bytes(full)} when full at {self.buffer.capacity})")
        return {"replay_buffer": state}

    def restore_extra(self, state: dict[str, Any]) -> None:
        """The replay buffer's contents when the checkpoint has them, else one line: it refills."""
        if "replay_buffer" in state:
            self.buffer.load_state_dict(state["replay_buffer"])
        else:
            log.warning(f"resume: the checkpoint holds no replay buffer (save_replay_buffer: False when it was "
                        f"written): it refills from empty, {self.cfg.batch_size} transitions before learning goes on")


def replay_bytes(state: dict[str, Any]) -> int:
    """Bytes of the tensors and arrays of a replay buffer's state_dict (about its size on disk)."""
    total = 0
    for value in state.values():
        if isinstance(value, dict):  # Dict observations kept per key
            total += replay_bytes(value)
        elif isinstance(value, list):
            total += sum(replay_bytes(v) for v in value if isinstance(v, dict))
        elif hasattr(value, "nbytes"):
            total += int(value.nbytes)
        elif isinstance(value, torch.Tensor):
            total += value.numel() * value.element_size()
    return total


def human_bytes(n: float) -> str:
    """``n`` bytes as KiB / MiB / GiB with one decimal."""
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n / 2**10:.1f} KiB"


def goal_reward_fn(compute_reward: Any, rs: Any, device: torch.device) -> Any:
    """Tensor goals (B, G) -> shaped rewards (B,) on ``device``: the env's ``compute_reward`` (numpy)
    followed by the run's reward_shaper, as every stored reward is shaped."""
    def reward(achieved: torch.Tensor, desired: torch.Tensor) -> torch.Tensor:
        raw = compute_reward(achieved.detach().cpu().numpy(), desired.detach().cpu().numpy(), None)
        raw = torch.as_tensor(raw, dtype=torch.float32, device=device).reshape(-1)
        return shape_with(raw, rs)
    return reward

