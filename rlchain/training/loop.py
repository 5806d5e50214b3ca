"""The one training loop: it holds an algorithm and runs ``collect -> update -> count -> log ->
checkpoint -> stop?``, with the counters, episode stats, events, stop rules, signals, divergence
rollback and checkpoints every algorithm shares.

The algorithm (:class:`rlchain.algos.base.algorithm.Algorithm`: PPO, SAC, DQN, APPO, ...) is built by the
Loop with the run's :class:`~rlchain.algos.base.context.RunContext` and never subclasses it. The Loop logs
whatever metrics ``update`` returns, under the algorithm's ``metric_tags``; checkpoints are
:class:`~rlchain.training.saving.CheckpointSaver`, PBT's live parameters
:class:`~rlchain.training.live_params.LiveParams`.
"""

from __future__ import annotations

import time
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol, runtime_checkable

import torch

from rlchain.algos.base.algorithm import Algorithm
from rlchain.algos.base.context import describe, make_context
from rlchain.algos.base.safety import DivergenceGuard, StopSignals, UpdateInterrupted, check_parameters
from rlchain.config.params import Params
from rlchain.envs.factory import build_env
from rlchain.envs.spec import env_spec
from rlchain.envs.vecenv import VecEnv
from rlchain.errors import CallbackError, DivergenceError, EnvError
from rlchain.log import get_logger, train_hint
from rlchain.parallel import communicator
from rlchain.parallel.communicator import Communicator
from rlchain.parallel.threads import ThreadPlan
from rlchain.runs.checkpoint import CheckpointError, seed_everything
from rlchain.runs.logging import TrainLogger
from rlchain.runs.run_dir import RunDir
from rlchain.training.callback_context import CallbackContext, RunRecord
from rlchain.training.env_events import event_callbacks
from rlchain.training.evaluation import EvaluationCallback
from rlchain.training.events import CallbackList, EnvStatsCallback, load_callback
from rlchain.training.hyperparam_schedule import HyperparamSchedule, check_names
from rlchain.training.learner_backup import LearnerBackup
from rlchain.training.live_params import LiveParams
from rlchain.training.saving import CheckpointSaver
from rlchain.training.self_play import SelfPlayCallback

__all__ = ["Loop", "TrainResult", "AlgorithmFactory", "tag_metrics"]

log = get_logger(__name__)

AlgorithmFactory = type[Algorithm]
"""What is registered as an algo: its class, built as ``cls(params, env, model, ctx)``."""


@runtime_checkable
class InterruptibleUpdate(Protocol):
    """Optional part of an :class:`~rlchain.algos.base.algorithm.Algorithm`: with ``interruptible_update`` True
    its ``update`` may raise UpdateInterrupted between minibatches on a stop signal (PPO); the Loop then puts
    back the learners (:meth:`learners`) of the epoch boundary. An algorithm without it finishes its update."""

    interruptible_update: ClassVar[bool]

    def learners(self) -> list[tuple[torch.nn.Module, Any]]:
        """(model, agent) pairs the update trains."""
        ...


@dataclass
class TrainResult:
    """What a finished run reports."""

    epoch: int
    frames: int
    mean_reward: float
    best_reward: float
    stop_reason: str
    run_dir: str
    seconds: float


class Loop:
    """The training loop of one run: it builds ``algorithm(params, env, model, ctx)`` and drives it."""

    def __init__(self, params: Params, algorithm: AlgorithmFactory, env: VecEnv, model: torch.nn.Module,
                 device: torch.device, run: RunDir | None, logger: TrainLogger, seed: int, raw_config: dict,
                 comm: Communicator | None = None, checked: bool = False, resuming: bool = False,
                 threads: ThreadPlan | None = None) -> None:
        """``checked``: the caller ran ``algorithm.check_config`` on this env already (the Runner does, before
        the model is built); ``resuming``: ``model`` holds the weights of the checkpoint :meth:`restore`
        will be given (the algorithm loads no others into it, and restore does not load them again);
        ``threads``: CPU threads per phase (the Runner's plan)."""
        cfg = params.config
        if not checked:
            algorithm.check_config(params, env_spec(env))  # before anything opens (PPO: its minibatch)
        self.params, self.env, self.model, self.raw_config = params, env, model, raw_config
        self.record = RunRecord()  # when train() started, the last epoch's results (callbacks' state)
        self._closed = False
        self.events = CallbackList([load_callback(name, params.source, f"params.config.callbacks[{i}]")
                                    for i, name in enumerate(cfg.callbacks)])
        # the other ranks (torchrun): the algorithm's agents and the episode statistics sync through it
        comm = comm if comm is not None else communicator.current()
        self.ctx = make_context(params, env, device, seed, comm, logger, self.events, threads=threads,
                                resuming=resuming)
        self._weights_loaded = resuming  # the first restore (the Runner's) finds them in the model already
        if self.ctx.spec.stats:  # backend counters (Ray: env/dropped_episodes)
            self.events.add(EnvStatsCallback())
        if cfg.evaluation.interval > 0:
            self.events.add(EvaluationCallback(cfg.evaluation, lambda n, s: build_env(params, n, s)))
        for callback in event_callbacks(getattr(cfg, "events", []), cfg.evaluation.interval > 0, params):
            self.events.add(callback)
        self.algorithm: Algorithm = algorithm(params, env, model, self.ctx)
        if self.algorithm.self_play and cfg.self_play_config is not None:  # opponents loaded into the env
            self.events.add(SelfPlayCallback(cfg.self_play_config, env, params.source))
        if cfg.hyperparam_schedule:  # a replayed PBT schedule, through set_params
            check_names(cfg.hyperparam_schedule, self.algorithm.tunable, params.algo.name, params.source)
            self.events.add(HyperparamSchedule(cfg.hyperparam_schedule))
        self.checkpoints = CheckpointSaver(self.ctx, self.algorithm, run, self.events)
        self.backup = LearnerBackup()  # the learner when an update starts (undone on a stop signal)
        self.live = LiveParams(self.ctx, self.algorithm)
        self.events.bind(CallbackContext(self.ctx, self.algorithm, model, self.checkpoints, self.live, self.events,
                                         self.record, raw_config))  # what every callback gets

    # ----- the loop -------------------------------------------------------------------------
    def train(self) -> TrainResult:
        """Train until max_epochs, max_frames, score_to_win or a stop signal; returns the statistics.

        SIGINT/SIGTERM stop after the current env step (or, in an ``interruptible_update``, the current
        minibatch, the update undone) with a checkpoint of the last completed epoch; an env failure does
        the same, then raises EnvError; a NaN/inf stops (or rolls back, with ``divergence.action:
        rollback``) without ever saving non-finite parameters. A final checkpoint that cannot be written
        raises CheckpointError.
        """
        start = self.record.started = time.time()
        algo, ctx = self.algorithm, self.ctx
        stop = self._limit_reached()  # a resumed run already at max_epochs / max_frames trains no further
        with StopSignals() as signals:
            ctx.signals = signals
            algo.start()
            self.checkpoints.point.after_start()
            self.checkpoints.point.capture()  # epoch boundary: what a stop during the first epoch saves
            self._snapshot()
            self.events.emit("on_train_start")
            while stop is None:
                self.live.apply_pending()
                t0 = time.time()
                try:
                    if not self._guarded_collect():
                        stop = signals.stop_reason()
                        break
                    self.events.emit("on_rollout_end")
                    t1 = time.time()
                    stats = self._guarded_update()
                except UpdateInterrupted:
                    stop = signals.stop_reason()
                    break
                except DivergenceError as exc:
                    self._diverged(exc)
                    continue  # rolled back: collect afresh with the restored learner
                if stats is None:
                    continue
                ctx.epoch += 1
                rollout_s, update_s = algo.epoch_seconds(t1 - t0, time.time() - t1)
                if ctx.info_means.keys:
                    stats = {**stats, **ctx.info_means.pop()}
                episodes = ctx.comm.episode_stats(ctx.tracker)  # under torchrun: every rank's games
                self.checkpoints.point.capture()  # the epoch boundary every checkpoint until the next one holds
                self._log(stats, episodes, rollout_s, update_s)
                self.checkpoints.after_epoch(episodes)
                if algo.snapshot_due():
                    self._snapshot()
                self.record.stats, self.record.episodes = stats, episodes
                algo.end_epoch(stats, episodes)
                self.events.emit("on_epoch_end", stats, episodes)
                stop = self._stop_reason(episodes)
            last = self.checkpoints.save("last")
        return self._finish(stop, start, last)

    def _guarded_collect(self) -> bool:
        """The algorithm's ``collect``; an env failure saves the last completed epoch, then raises EnvError."""
        try:
            return self.algorithm.collect()
        except (EnvError, DivergenceError, KeyboardInterrupt):
            raise
        except CallbackError as exc:  # the user's callback, not the env: their own exception, as it was
            path = self.checkpoints.save("last")
            saved = f"; last completed epoch {self.ctx.epoch} saved to {path}" if path else ""
            log.error(f"error: {exc} (epoch {self.ctx.epoch + 1}){saved}")
            raise exc.__cause__ from None
        except Exception as exc:
            path = self.checkpoints.save("last")
            epoch = self.ctx.epoch
            saved = f"; last completed epoch {epoch} saved to {path}" if path else ""
            raise EnvError(f"env step failed at epoch {epoch + 1}: {describe(exc)}{saved}") from exc

    def _guarded_update(self) -> dict[str, float] | None:
        """``update`` (under the update's thread count while the envs wait); non-finite parameters diverge.
        An algorithm that leaves its update on a stop signal (``interruptible_update``) gets the learner of
        the epoch boundary back, so the checkpoint then written resumes exactly."""
        algo = self.algorithm
        interruptible = isinstance(algo, InterruptibleUpdate) and algo.interruptible_update and not self.ctx.comm.active
        if interruptible:
            self.backup.capture(algo.learners())
        try:
            with self.ctx.update_phase() if algo.envs_idle_in_update else nullcontext():
                stats = algo.update()
        except UpdateInterrupted:
            if interruptible:
                self.backup.restore(algo.learners())
            raise
        if stats is None:
            return None
        self.ctx.frames += 0 if algo.counts_frames_while_collecting else algo.frames_per_epoch()
        bad = check_parameters(algo.model)
        if bad is not None:
            raise DivergenceError(f"{bad} became non-finite in the update")
        return stats

    def _diverged(self, exc: DivergenceError) -> None:
        """A NaN/inf: roll back to the last snapshot and restart the envs' episodes (``divergence.action:
        rollback``, within max_rollbacks), else save what is finite and raise naming the epoch."""
        guard: DivergenceGuard | None = self.algorithm.divergence
        if guard is None:
            raise exc
        try:
            guard.handle(exc, self.ctx.epoch)
        except DivergenceError:
            self.checkpoints.save("last")  # the restored, finite parameters (a non-finite model is never saved)
            raise
        self.checkpoints.restart_episodes()

    def _snapshot(self) -> None:
        """The divergence guard's in-memory copy of the learner (what a rollback restores)."""
        if self.algorithm.divergence is not None:
            self.algorithm.divergence.snapshot(self.ctx.epoch)

    # ----- checkpoints ------------------------------------------------------------------------
    def restore(self, state: dict[str, Any], path: str) -> None:
        """Continue from a checkpoint: weights (unless the model was built holding this checkpoint's:
        the first restore of a run made with ``resuming``), optimizer(s), lr, normalizers, counters, RNG."""
        self.checkpoints.restore(state, path, weights=not self._weights_loaded)
        self._weights_loaded = False  # a later restore (PBT's exploit, a tuning trial) loads its weights

    # ----- the run around the loop ------------------------------------------------------------
    def close(self) -> None:
        """Close what the run opened besides the training env (the evaluation env, callbacks'
        resources, the algorithm's own): once, on every exit path. The training env belongs to whoever built it."""
        if self._closed:
            return
        self._closed = True
        try:
            self.events.close()
        finally:
            if getattr(self, "algorithm", None) is not None:
                self.algorithm.close()

    @classmethod
    def create(cls, *args: Any, **kwargs: Any) -> Loop:
        """``cls(*args, **kwargs)``, but a constructor that fails half-way (a config error, a replay
        buffer too big for memory) first closes what it had opened (the evaluation env)."""
        loop = cls.__new__(cls)
        try:
            loop.__init__(*args, **kwargs)
        except BaseException:
            if isinstance(getattr(loop, "events", None), CallbackList):
                loop.events.close()
            raise
        return loop

    def join_ranks(self) -> None:
        """Under torchrun, once the run is built (and resumed): every rank takes rank 0's parameters,
        buffers and optimizer state; after a resume from a checkpoint without every rank's own state
        (an older one, another world size), which restored rank 0's RNG state everywhere, the other
        ranks reseed their own streams."""
        comm = self.ctx.comm
        if not comm.active:
            return
        for model, agent in self.algorithm.learners():
            comm.broadcast_learner(model, agent)
        epoch = self.ctx.epoch
        if epoch > 0 and not comm.is_main and not self.checkpoints.point.rank_restored:
            seed_everything(comm.rank_seed + epoch)  # a checkpoint without every rank's own streams

    def _limit_reached(self) -> str | None:
        """At the start: the stop a run resumed at or past its max_epochs / max_frames has reached already."""
        cfg, epoch, frames = self.ctx.cfg, self.ctx.epoch, self.ctx.frames
        if cfg.max_epochs > 0 and epoch >= cfg.max_epochs:
            return f"max_epochs {cfg.max_epochs} reached (the checkpoint is at epoch {epoch}; nothing to train)"
        if cfg.max_frames > 0 and frames >= cfg.max_frames:
            return f"max_frames {cfg.max_frames} reached (the checkpoint is at frame {frames}; nothing to train)"
        return None

    def _stop_reason(self, episodes: dict | None) -> str | None:
        ctx = self.ctx
        cfg = ctx.cfg
        if episodes is not None and episodes["reward"] >= cfg.score_to_win:
            return f"score_to_win {cfg.score_to_win} reached"
        if episodes is not None and episodes.get("success", -1.0) >= cfg.success_to_win:
            return f"success_to_win {cfg.success_to_win} reached"
        if cfg.max_epochs > 0 and ctx.epoch >= cfg.max_epochs:
            return f"max_epochs {cfg.max_epochs} reached"
        if cfg.max_frames > 0 and ctx.frames >= cfg.max_frames:
            return f"max_frames {cfg.max_frames} reached"
        if ctx.signals is not None and ctx.signals.requested:
            return ctx.signals.stop_reason()
        return None

    def _finish(self, stop: str, start: float, last: str | None) -> TrainResult:
        """Report the stop, emit on_train_end and build the result. A final checkpoint that could not be
        written ends the run with a CheckpointError (non-zero exit) whose line is the stop line and why."""
        ctx, saver = self.ctx, self.checkpoints
        tracker, run, best = ctx.tracker, saver.run, saver.best_reward
        ctx.logger.flush()
        mean = tracker.mean_return() if tracker.has_data else float("nan")
        if ctx.comm.world_size > 1 and self.record.episodes is not None:  # every rank's games, as `best` is
            mean = self.record.episodes["reward"]
        interrupted = stop.startswith("interrupted")
        success = f", success rate {tracker.success_rate():.2f}" if tracker.has_success else ""
        head = stop if stop.startswith("stopped") else f"stopped: {stop}"  # not 'stopped: stopped by ...'
        line = (f"{head} at epoch {ctx.epoch}, frames {ctx.frames}, mean reward {mean:.2f}, "
                f"best {best:.2f}{success}")
        failures = saver.failures_line()
        if failures:
            log.warning(failures)
        lost = run is not None and last is None and saver.failure is not None
        if lost:
            line += f"; the final checkpoint was not written ({saver.failure}); {saver.kept()}"
        if (ctx.cfg.print_stats or interrupted) and not (lost and not interrupted):
            log.info(line)
        if interrupted and last:
            log.info(f"resume with: {train_hint(self.params.source, last)}")
        result = TrainResult(ctx.epoch, ctx.frames, mean, best, stop, run.root if run else "", time.time() - start)
        self.events.emit("on_train_end", result)
        if lost and not interrupted:  # an interrupted run exits non-zero already (130), its line says what is kept
            raise CheckpointError(line)
        return result

    def _log(self, stats: dict[str, float], episodes: dict | None, rollout_s: float, update_s: float) -> None:
        """The epoch's TensorBoard scalars and console line: the metrics under the algorithm's ``metric_tags``."""
        algo, ctx = self.algorithm, self.ctx
        cfg, best = ctx.cfg, self.checkpoints.best_reward
        timing = {"batch": algo.frames_per_epoch(), "rollout": rollout_s, "update": update_s}
        console = [fmt.format(stats[name]) for name, fmt in algo.console_fields if name in stats]
        best = best if episodes is None else max(best, episodes["reward"])  # with this epoch
        ctx.logger.epoch(ctx.epoch, cfg.max_epochs, ctx.frames, tag_metrics(stats, algo.metric_tags),
                         episodes, best, timing, console, cfg.max_frames, cfg.score_to_win)


def tag_metrics(stats: dict[str, float], tags: dict[str, str]) -> dict[str, float]:
    """``{tag: value}`` of the metrics ``tags`` names, plus those whose name already is a tag
    (``losses/aux_l2``); other metrics (counts, internal values) are for callbacks only."""
    out = {}
    for name, value in stats.items():
        tag = tags.get(name, name if "/" in name else None)
        if tag is not None:
            out[tag] = float(value)
    return out
