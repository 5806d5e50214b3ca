"""What a callback sees of a training run: a :class:`CallbackContext`, the one face callbacks get.

Every :class:`~rlchain.training.events.Callback` method gets the run's context as its first
argument. It offers a typed, read-only snapshot of the run (:attr:`CallbackContext.state`, a frozen
:class:`TrainingState`), the actions a callback may take (:meth:`~CallbackContext.request_stop`,
``save``, ``get_params`` / ``set_params``) and the run's parts, read directly: the policy
:attr:`~CallbackContext.model` (evaluation, video), a TensorBoard :attr:`~CallbackContext.writer`, the
:attr:`~CallbackContext.env_spec`, the run's typed :attr:`~CallbackContext.params` and, for callbacks that
reach into training (replay buffers, rollout storage, test instruments), the :attr:`~CallbackContext.algorithm`.
The loop builds it from the parts it holds; the context never goes through the loop.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Protocol

import torch

from rlchain.algos.base.algorithm import Algorithm
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.episodes import EpisodeTracker
from rlchain.envs.spec import EnvSpec
from rlchain.envs.vecenv import VecEnv
from rlchain.runs.run_dir import RunDir
from rlchain.training.live_params import LiveParams

EMITTABLE = ("on_evaluation", "on_stats_cleared")
"""Events a callback may announce to the other callbacks through :meth:`CallbackContext.emit`."""


class Checkpoints(Protocol):
    """The run's checkpoints (:class:`rlchain.training.saving.CheckpointSaver`), as the context uses them."""

    run: RunDir | None
    best_reward: float

    def save(self, kind: str) -> str | None: ...

    def state_dict(self, kind: str = "last") -> dict[str, Any]: ...

    def restore(self, state: dict[str, Any], path: str, weights: bool = True) -> None: ...

    def restart_episodes(self) -> None: ...


class Events(Protocol):
    """The run's callbacks (:class:`rlchain.training.events.CallbackList`), as the context uses them."""

    def emit(self, event: str, *args: Any) -> None: ...


@dataclass
class RunRecord:
    """What the loop records of a run for :attr:`CallbackContext.state` beyond the counters (which the
    :class:`~rlchain.algos.base.context.RunContext` holds): when ``train()`` started, the last epoch's results."""

    started: float = field(default_factory=time.time)
    stats: dict[str, float] = field(default_factory=dict)  # the last epoch's metrics, as update() returned them
    episodes: dict[str, float] | None = None  # the last epoch's episode means (None: no game ended yet)


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


def tensorboard_call(method: str) -> Callable[..., None]:
    """A :class:`ScalarWriter` method: SummaryWriter's ``method`` on the run's TensorBoard writer."""

    def call(self: ScalarWriter, *args: Any, **kwargs: Any) -> None:
        self.run.logger.write(method, *args, **kwargs)
    call.__name__ = call.__qualname__ = method
    call.__doc__ = f"SummaryWriter.{method} on the run's TensorBoard writer (nothing without one)."
    return call


class ScalarWriter:
    """TensorBoard for callbacks: ``add_scalar(tag, value, step)`` (to every log writer: TensorBoard,
    wandb, the config's ``log_writers``) and the other SummaryWriter methods below on the run's TensorBoard
    writer. Without a run folder (or after a failed write) they do nothing."""

    def __init__(self, run: RunContext) -> None:
        self.run = run  # its logger, live: a Ray Tune trial moves the run to another folder

    def add_scalar(self, tag: str, scalar_value: float, global_step: int | None = None,
                   walltime: float | None = None) -> None:
        """Write one scalar; ``global_step`` defaults to the run's frames."""
        step = self.run.frames if global_step is None else global_step
        self.run.logger.write("add_scalar", tag, float(scalar_value), step, walltime)

    add_scalars = tensorboard_call("add_scalars")
    add_histogram = tensorboard_call("add_histogram")
    add_image = tensorboard_call("add_image")
    add_images = tensorboard_call("add_images")
    add_figure = tensorboard_call("add_figure")
    add_video = tensorboard_call("add_video")
    add_audio = tensorboard_call("add_audio")
    add_text = tensorboard_call("add_text")
    add_hparams = tensorboard_call("add_hparams")
    flush = tensorboard_call("flush")


class CallbackContext:
    """A training run as callbacks see it (see the module docstring). One per run, built by the loop
    from its parts once the algorithm exists.

    The handles are the run's own objects (``ctx.algorithm`` is the algorithm the loop drives); read
    them, do not replace them. ``save(kind)``, ``get_params()``, ``set_params(**changes)`` and
    ``full_state()`` are the checkpoint saver's and the live parameters' own methods.
    """

    def __init__(self, run: RunContext, algorithm: Algorithm, model: torch.nn.Module, checkpoints: Checkpoints,
                 live: LiveParams, events: Events, record: RunRecord, raw_config: dict) -> None:
        self._run, self._checkpoints, self._events, self._record = run, checkpoints, events, record
        self.algorithm = algorithm
        """The algorithm the loop drives (its ``agent``, ``storage``, ``buffer`` ...): for callbacks that reach
        into training."""
        self.model = model
        """The policy being trained (for evaluation and videos; put it back in train mode after use)."""
        self.params: Any = run.params
        """The run's typed configuration (``params.config``, ``params.algo``, ...): read it, do not change it."""
        self.env_spec: EnvSpec = run.spec
        """The training envs' frozen :class:`rlchain.envs.spec.EnvSpec`: number, agents, spaces, value size,
        mask size, tensor or numpy stepping, groups."""
        self.training_env: VecEnv = run.env
        """The training env itself: what an env event is called with, what reports backend counters and
        takes self-play's opponents."""
        self.raw_config = raw_config
        """The configuration as written (rl_games' ``algo.config`` and a moved run's folder read it)."""
        self.writer = ScalarWriter(run)
        """The run's TensorBoard writer (``add_scalar(tag, value, step)``)."""
        self.save: Callable[[str], str | None] = checkpoints.save
        """``save(kind)``: write a checkpoint of ``kind`` (best, last, ep_N) now; its path, or None when none
        was written (no run folder, non-finite parameters, a failed write)."""
        self.full_state: Callable[[], dict[str, Any]] = functools.partial(checkpoints.state_dict, "last")
        """``full_state()``: everything exact resume needs, as a ``last`` checkpoint holds it."""
        self.get_params: Callable[[], dict[str, float]] = live.get_params
        """``get_params()``: the live values of the training parameters ``set_params`` may change."""
        self.set_params: Callable[..., None] = live.set_params
        """``set_params(**changes)``: change training parameters from the next epoch on (thread-safe; logged
        as ``params/*``)."""

    @property
    def state(self) -> TrainingState:
        """The run's counters, last statistics and identity, as of now."""
        run, record, cfg, folder = self._run, self._record, self._run.cfg, self._checkpoints.run
        return TrainingState(
            epoch=int(run.epoch), frames=int(run.frames), seconds=time.time() - record.started,
            best_reward=float(self._checkpoints.best_reward),
            episodes=MappingProxyType(dict(record.episodes)) if record.episodes is not None else None,
            stats=MappingProxyType(dict(record.stats)), algo=run.params.algo.name, name=cfg.name,
            experiment_dir=folder.root if folder is not None else "", device=run.device, seed=int(run.seed),
            rank=run.comm.rank, world_size=run.comm.world_size, max_epochs=int(cfg.max_epochs),
            max_frames=int(cfg.max_frames), scalars=MappingProxyType(dict(getattr(run.logger, "last_scalars", {}))))

    # ----- what callbacks that drive the run need (env events, backend counters, self-play, tuning, rl_games) ----
    @property
    def episode_tracker(self) -> EpisodeTracker:
        """The run's episode statistics, live (self-play scores the finished games)."""
        return self._run.tracker

    @property
    def agent(self) -> Any:
        """The algorithm's agent (``optimizer``, ``lr``: what rl_games' observers read); None without one."""
        return getattr(self.algorithm, "agent", None)

    @property
    def run_dir(self) -> RunDir | None:
        """The run folder (a RunDir), None when the run writes none."""
        return self._checkpoints.run

    def scalar(self, tag: str, value: float) -> None:
        """Write one scalar at the run's frames to every log writer."""
        self.writer.add_scalar(tag, float(value))

    def frames_per_epoch(self) -> int:
        """Env frames one epoch adds (every rank's)."""
        return int(self.algorithm.frames_per_epoch())

    def load_full_state(self, state: dict[str, Any], source: str, keep_counters: bool = False) -> None:
        """Load :attr:`full_state` (read from ``source``) into the running training; the envs start fresh
        episodes. ``keep_counters`` keeps this run's epoch and frame counters."""
        run = self._run
        epoch, frames = run.epoch, run.frames
        self._checkpoints.restore(state, source)
        if keep_counters:
            run.epoch, run.frames = epoch, frames
        self._checkpoints.restart_episodes()

    def snapshot(self) -> None:
        """The learner as it is now is the one a divergence rollback returns to."""
        guard = self.algorithm.divergence
        if guard is not None:
            guard.snapshot(self._run.epoch)

    def move_run(self, run: RunDir, writers: list[Any]) -> Any:
        """Log and checkpoint into ``run`` from now on, through a logger like the run's own (its console, progress
        and rl_games' tags) with ``writers`` (``run``'s own); closes the logger it replaces and returns the new
        one (the caller closes it when the run ends)."""
        old = self._run.logger
        self._run.logger, self._checkpoints.run = old.moved(run.summaries, writers), run
        old.close()
        return self._run.logger

    def request_stop(self, reason: str) -> None:
        """Stop after the current epoch with a checkpoint, as a signal would."""
        if self._run.signals is not None:
            self._run.signals.request(reason)

    def emit(self, event: str, *args: Any) -> None:
        """Announce an event this callback produced to every callback: ``on_evaluation(result)``
        after an evaluation, ``on_stats_cleared()`` after statistics were reset."""
        if event not in EMITTABLE:
            raise ValueError(f"callbacks may emit {' or '.join(EMITTABLE)}, not '{event}'")
        self._events.emit(event, *args)


class ObserverAlgo:
    """What an rl_games AlgoObserver's ``after_init(algo)`` gets: the attributes observers read of
    rl_games' algo (``writer``, ``device`` / ``ppo_device``, ``games_to_track``, ``epoch_num``,
    ``frame``, ``num_actors``, ``num_agents``, ``config``, ``experiment_dir``, ``train_dir``, ``model``,
    ``optimizer``, ``last_lr``, ``get_full_state_weights`` / ``set_full_state_weights``), live, from the
    run's :class:`CallbackContext`; nothing else."""

    def __init__(self, context: CallbackContext, in_epoch: bool = False) -> None:
        self._context = context
        self.in_epoch = in_epoch
        """True while an epoch runs (its env steps, after_steps): ``epoch_num`` then counts it, as rl_games
        increments its counter before an epoch's rollout; False in after_init and after_print_stats."""
        cfg = context.params.config
        self.writer = context.writer
        self.device = self.ppo_device = context.state.device
        self.games_to_track = int(cfg.games_to_track)
        self.num_actors = int(context.training_env.num_envs)
        self.num_agents = int(context.env_spec.num_agents)
        self.train_dir = str(cfg.train_dir)
        """The folder that holds the run folders (``params.config.train_dir``)."""
        raw = context.raw_config
        self.config: dict = raw.get("params", raw).get("config", {}) if isinstance(raw, dict) else {}
        """The run's ``params.config`` block as written (rl_games' ``algo.config`` dict)."""
        self.model = context.model
        self.get_full_state_weights: Callable[[], dict[str, Any]] = context.full_state
        """Everything exact resume needs, as a checkpoint holds it (rl_games' name)."""

    @property
    def epoch_num(self) -> int:
        """rl_games' epoch counter: the epochs completed, plus the one running while ``in_epoch``."""
        return int(self._context.state.epoch) + (1 if self.in_epoch else 0)

    @property
    def frame(self) -> int:
        """Env frames so far."""
        return int(self._context.state.frames)

    @property
    def experiment_dir(self) -> str:
        """The run folder ("" when the run writes none); a Ray Tune trial moves it."""
        run = self._context.run_dir
        return run.root if run is not None else ""

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

    def set_full_state_weights(self, weights: dict[str, Any], set_epoch: bool = True) -> None:
        """Load what :meth:`get_full_state_weights` returned into the running training; the envs start fresh
        episodes. ``set_epoch=False`` keeps this run's epoch and frame counters."""
        self._context.load_full_state(weights, "<full state weights>", keep_counters=not set_epoch)
