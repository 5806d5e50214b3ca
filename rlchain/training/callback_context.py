"""What a callback sees of a training run: a :class:`CallbackContext`, not the trainer.

Every :class:`~rlchain.training.events.Callback` method gets the run's context as its first
argument. It offers a typed, read-only snapshot of the run (:attr:`CallbackContext.state`, a frozen
:class:`TrainingState`), the actions a callback may take (:meth:`~CallbackContext.request_stop`,
:meth:`~CallbackContext.save`, :meth:`~CallbackContext.set_params`) and the few handles callbacks
need: the policy :attr:`~CallbackContext.model` (evaluation, video), a TensorBoard
:attr:`~CallbackContext.writer`, the :attr:`~CallbackContext.env_spec` and the run's typed
:attr:`~CallbackContext.params`.

Callbacks written for the older API read the trainer's attributes (``trainer.epoch``,
``trainer.logger``...); for one release the context forwards any other attribute to the trainer
with a :class:`DeprecationWarning` naming it (once per attribute and run).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import torch

from rlchain.algos.base.episodes import EpisodeTracker
from rlchain.envs.spec import EnvSpec
from rlchain.envs.vecenv import VecEnv

EMITTABLE = ("on_evaluation", "on_stats_cleared")
"""Events a callback may announce to the other callbacks through :meth:`CallbackContext.emit`."""


@dataclass(frozen=True)
class TrainingState:
    """The run at the moment a callback reads :attr:`CallbackContext.state` (a copy: it does not change)."""

    epoch: int  # epochs completed
    frames: int  # env frames so far, every rank's under torchrun
    seconds: float  # wall time since train() started
    best_reward: float  # best mean reward of the tracked games so far (-inf before any)
    episodes: Mapping[str, float] | None  # the last epoch's episode means: reward, length (success); None if none
    stats: Mapping[str, float]  # the last epoch's metrics as update() returned them (raw names; tagged: scalars)
    algo: str  # params.algo.name
    name: str  # params.config.name
    experiment_dir: str  # the run folder ("" when the run writes none)
    device: torch.device  # the training device
    seed: int
    rank: int  # this process under torchrun (0 otherwise)
    world_size: int  # processes training together
    max_epochs: int  # stop rules from the config (-1: none)
    max_frames: int
    scalars: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    """The last epoch's scalars under their TensorBoard tags (``rewards/step``, ``losses/a_loss``,
    ``performance/step_fps`` ...), exactly as every log writer got them; empty before the first epoch."""

    @property
    def is_main(self) -> bool:
        """Rank 0: the process that writes logs and checkpoints."""
        return self.rank == 0


def training_state(trainer: Any) -> TrainingState:
    """A :class:`TrainingState` of ``trainer`` (a Loop) now."""
    cfg = trainer.cfg
    episodes = getattr(trainer, "last_episodes", None)
    started = getattr(trainer, "started", None)
    return TrainingState(
        epoch=int(trainer.epoch), frames=int(trainer.frames),
        seconds=time.time() - started if started is not None else 0.0,
        best_reward=float(trainer.best_reward),
        episodes=MappingProxyType(dict(episodes)) if episodes is not None else None,
        stats=MappingProxyType(dict(getattr(trainer, "last_stats", None) or {})),
        algo=trainer.params.algo.name, name=cfg.name,
        experiment_dir=trainer.run.root if trainer.run is not None else "",
        device=trainer.device, seed=int(trainer.seed), rank=trainer.comm.rank, world_size=trainer.comm.world_size,
        max_epochs=int(cfg.max_epochs), max_frames=int(cfg.max_frames),
        scalars=MappingProxyType(dict(getattr(getattr(trainer, "logger", None), "last_scalars", None) or {})))


class ScalarWriter:
    """TensorBoard for callbacks: ``add_scalar(tag, value, step)`` (to every log writer: TensorBoard,
    wandb, the config's ``log_writers``) and the other SummaryWriter methods on the run's TensorBoard
    writer. Without a run folder (or after a failed write) they do nothing."""

    def __init__(self, trainer: Any) -> None:
        self._trainer = trainer

    def add_scalar(self, tag: str, scalar_value: float, global_step: int | None = None,
                   walltime: float | None = None) -> None:
        """Write one scalar; ``global_step`` defaults to the run's frames."""
        step = self._trainer.frames if global_step is None else global_step
        self._trainer.logger.write("add_scalar", tag, float(scalar_value), step, walltime)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        return lambda *args, **kwargs: self._trainer.logger.write(name, *args, **kwargs)


class CallbackContext:
    """A training run as callbacks see it (see the module docstring). One per run."""

    def __init__(self, trainer: Any) -> None:
        object.__setattr__(self, "_trainer", trainer)
        object.__setattr__(self, "_warned", set())
        object.__setattr__(self, "_writer", ScalarWriter(trainer))

    @property
    def state(self) -> TrainingState:
        """The run's counters, last statistics and identity, as of now."""
        return training_state(self._trainer)

    @property
    def model(self) -> torch.nn.Module:
        """The policy being trained (for evaluation and videos; put it back in train mode after use)."""
        return self._trainer.model

    @property
    def writer(self) -> ScalarWriter:
        """The run's TensorBoard writer (``add_scalar(tag, value, step)``)."""
        return self._writer

    @property
    def params(self) -> Any:
        """The run's typed configuration (``params.config``, ``params.algo``, ...): read it, do not change it."""
        return self._trainer.params

    @property
    def env_spec(self) -> EnvSpec:
        """The training envs' frozen :class:`rlchain.envs.spec.EnvSpec`: number, agents, spaces, value size,
        mask size, tensor or numpy stepping, groups."""
        return self._trainer.env_spec

    # ----- what callbacks that drive the run need (env events, backend counters, self-play, tuning, rl_games) ----
    @property
    def training_env(self) -> VecEnv:
        """The training env itself: what an env event is called with, what reports backend counters and takes
        self-play's opponents."""
        return self._trainer.env

    @property
    def episode_tracker(self) -> EpisodeTracker:
        """The run's episode statistics, live (self-play scores the finished games)."""
        return self._trainer.ctx.tracker

    @property
    def agent(self) -> Any:
        """The algorithm's agent (``optimizer``, ``lr``: what rl_games' observers read); None without one."""
        return getattr(self._trainer.algorithm, "agent", None)

    @property
    def raw_config(self) -> dict:
        """The configuration as written (rl_games' ``algo.config`` and a moved run's folder read it)."""
        return self._trainer.raw_config

    def scalar(self, tag: str, value: float) -> None:
        """Write one scalar at the run's frames to every log writer."""
        self._trainer.logger.scalar(tag, float(value), self._trainer.frames)

    def frames_per_epoch(self) -> int:
        """Env frames one epoch adds (every rank's)."""
        return int(self._trainer.frames_per_epoch())

    def full_state(self) -> dict[str, Any]:
        """Everything exact resume needs, as a ``last`` checkpoint holds it."""
        return self._trainer.state_dict("last")

    def load_full_state(self, state: dict[str, Any], source: str, keep_counters: bool = False) -> None:
        """Load :meth:`full_state` (read from ``source``) into the running training; the envs start fresh episodes.
        ``keep_counters`` keeps this run's epoch and frame counters."""
        trainer = self._trainer
        epoch, frames = trainer.epoch, trainer.frames
        trainer.restore(state, source)
        if keep_counters:
            trainer.ctx.epoch, trainer.ctx.frames = epoch, frames
        trainer.restart_episodes()

    def snapshot(self) -> None:
        """The learner as it is now is the one a divergence rollback returns to."""
        self._trainer.snapshot()

    def move_run(self, run: Any, logger: Any) -> Any:
        """Log and checkpoint into ``run`` (a RunDir) through ``logger`` from now on; returns the logger it
        replaces (the caller closes it)."""
        trainer = self._trainer
        old = trainer.logger
        trainer.logger, trainer.run = logger, run
        return old

    @property
    def run_dir(self) -> Any:
        """The run folder (a RunDir), None when the run writes none."""
        return self._trainer.run

    def request_stop(self, reason: str) -> None:
        """Stop after the current epoch with a checkpoint, as a signal would."""
        self._trainer.request_stop(reason)

    def save(self, kind: str) -> str | None:
        """Write a checkpoint of ``kind`` (best, last, ep_N) now; its path, or None when none was
        written (no run folder, non-finite parameters, a failed write)."""
        return self._trainer.save(kind)

    def get_params(self) -> dict[str, float]:
        """The live values of the training parameters :meth:`set_params` may change."""
        return self._trainer.get_params()

    def set_params(self, **changes: float) -> None:
        """Change training parameters from the next epoch on (thread-safe; logged as ``params/*``)."""
        self._trainer.set_params(**changes)

    def emit(self, event: str, *args: Any) -> None:
        """Announce an event this callback produced to every callback: ``on_evaluation(result)``
        after an evaluation, ``on_stats_cleared()`` after statistics were reset."""
        if event not in EMITTABLE:
            raise ValueError(f"callbacks may emit {' or '.join(EMITTABLE)}, not '{event}'")
        self._trainer.events.emit(event, *args)

    def __getattr__(self, name: str) -> Any:
        """The trainer's attribute, deprecated: callbacks read :attr:`state` and the handles above."""
        if name.startswith("__"):
            raise AttributeError(name)
        trainer = self._trainer
        if not hasattr(trainer, name):  # the loop's, else its algorithm's (the agent, the storage ...)
            trainer = getattr(trainer, "algorithm", None)
            if trainer is None or not hasattr(trainer, name):
                raise AttributeError(f"a callback context has no attribute '{name}' (see "
                                     f"rlchain.training.callback_context.CallbackContext)")
        self._deprecated(name)
        return getattr(trainer, name)

    def __setattr__(self, name: str, value: Any) -> None:
        self._deprecated(name)
        setattr(self._trainer, name, value)

    def _deprecated(self, name: str) -> None:
        if name in self._warned:
            return
        self._warned.add(name)
        warnings.warn(f"callbacks get a CallbackContext, not the trainer: 'trainer.{name}' is deprecated and "
                      f"will be removed in the next release; read context.state (epoch, frames, best_reward, "
                      f"stats ...) or its model / writer / params / env_spec / save / request_stop / set_params",
                      DeprecationWarning, stacklevel=3)


class ObserverAlgo:
    """What an rl_games AlgoObserver's ``after_init(algo)`` gets: the attributes observers read of
    rl_games' algo (``writer``, ``device`` / ``ppo_device``, ``games_to_track``, ``epoch_num``,
    ``frame``, ``num_actors``, ``num_agents``, ``config``, ``experiment_dir``, ``train_dir``, ``optimizer``,
    ``last_lr``, ``get_full_state_weights`` / ``set_full_state_weights``), live; anything
    else goes to the :class:`CallbackContext` (the trainer's attributes, deprecated)."""

    def __init__(self, context: CallbackContext, in_epoch: bool = False) -> None:
        self._context = context
        self.in_epoch = in_epoch
        """True while an epoch runs (its env steps, after_steps): ``epoch_num`` then counts it, as rl_games
        increments its counter before an epoch's rollout; False in after_init and after_print_stats."""

    @property
    def writer(self) -> ScalarWriter:
        return self._context.writer

    @property
    def device(self) -> torch.device:
        return self._context.state.device

    ppo_device = device

    @property
    def games_to_track(self) -> int:
        return int(self._context.params.config.games_to_track)

    @property
    def epoch_num(self) -> int:
        """rl_games' epoch counter: the epochs completed, plus the one running while ``in_epoch``."""
        return int(self._context.state.epoch) + (1 if self.in_epoch else 0)

    @property
    def frame(self) -> int:
        return int(self._context.state.frames)

    @property
    def num_actors(self) -> int:
        return int(self._context.training_env.num_envs)

    @property
    def num_agents(self) -> int:
        return int(self._context.env_spec.num_agents)

    @property
    def config(self) -> dict:
        """The run's ``params.config`` block as written (rl_games' ``algo.config`` dict)."""
        raw = self._context.raw_config
        return raw.get("params", raw).get("config", {}) if isinstance(raw, dict) else {}

    @property
    def experiment_dir(self) -> str:
        return self._context.state.experiment_dir

    @property
    def train_dir(self) -> str:
        """The folder that holds the run folders (``params.config.train_dir``)."""
        return str(self._context.params.config.train_dir)

    @property
    def optimizer(self) -> Any:
        """The policy's optimizer (None for an algorithm without one)."""
        return getattr(self._context.agent, "optimizer", None)

    @property
    def last_lr(self) -> float:
        """The learning rate now: the agent's ``lr`` (the adaptive schedule's), else the optimizer's."""
        lr = getattr(self._context.agent, "lr", None)
        if lr is None and self.optimizer is not None:
            lr = self.optimizer.param_groups[0]["lr"]
        return float(lr) if lr is not None else 0.0

    def get_full_state_weights(self) -> dict[str, Any]:
        """Everything exact resume needs, as a checkpoint holds it (rl_games' name)."""
        return self._context.full_state()

    def set_full_state_weights(self, weights: dict[str, Any], set_epoch: bool = True) -> None:
        """Load what :meth:`get_full_state_weights` returned into the running training; the envs start fresh
        episodes. ``set_epoch=False`` keeps this run's epoch and frame counters."""
        self._context.load_full_state(weights, "<full state weights>", keep_counters=not set_epoch)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self._context, name)
