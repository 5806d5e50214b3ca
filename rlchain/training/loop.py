"""The one training loop: counters, episode stats, events, stop rules, signals, divergence, checkpoints.

:class:`Loop` runs ``collect -> update -> count -> log -> checkpoint -> stop?`` for any algorithm
that fills in the hooks of :class:`rlchain.training.algorithm.Algorithm` (PPO, SAC and DQN do);
``extra_state`` / ``restore_extra`` add what an algorithm's checkpoints carry beyond the Loop's.
The Loop logs whatever metrics ``update`` returns, under the algorithm's ``metric_tags``.
"""

from __future__ import annotations

import math
import time
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch

from rlchain.config.load import check_batch
from rlchain.config.schema import Params
from rlchain.envs.spec import env_spec
from rlchain.envs.vecenv import dropped_rows
from rlchain.envs.wrappers.info_means import InfoMeans
from rlchain.envs.wrappers.success import SuccessReader
from rlchain.errors import DivergenceError, EnvError
from rlchain.log import get_logger
from rlchain.models.build import build_env
from rlchain.parallel import communicator
from rlchain.parallel.communicator import Communicator
from rlchain.parallel.threads import ThreadPlan
from rlchain.runs.checkpoint import seed_everything
from rlchain.runs.logging import EnvStatsCallback, TrainLogger
from rlchain.runs.run_dir import RunDir
from rlchain.training.episodes import EpisodeTracker, game_outcome
from rlchain.training.evaluation import EvaluationCallback
from rlchain.training.events import CallbackList, load_callback
from rlchain.training.hyperparam_schedule import HyperparamSchedule, check_names
from rlchain.training.live_params import LiveParamsMixin
from rlchain.training.loop_checkpoint import CheckpointMixin
from rlchain.training.safety import DivergenceGuard, StopSignals, check_obs_shape, check_parameters
from rlchain.training.self_play import SelfPlayCallback

log = get_logger(__name__)


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


class Loop(LiveParamsMixin, CheckpointMixin):
    """The training loop and its bookkeeping; an algorithm subclasses it, sets ``self.agent`` (and
    ``self.divergence``) and implements the hooks of :class:`rlchain.training.algorithm.Algorithm`."""

    metric_tags: ClassVar[dict[str, str]] = {}
    console_fields: ClassVar[tuple[tuple[str, str], ...]] = ()
    tunable: ClassVar[tuple[str, ...]] = ()
    supports_distributed: ClassVar[bool] = False
    env_self_play: ClassVar[bool] = True  # self_play_config loads opponents into the env (set_opponent)

    def __init__(self, params: Params, env: Any, model: torch.nn.Module, device: torch.device,
                 run: RunDir | None, logger: TrainLogger, seed: int, raw_config: dict,
                 comm: Communicator | None = None) -> None:
        cfg = params.config
        # the other ranks (torchrun): the algorithm's agents and the episode statistics sync through it
        self.comm = comm if comm is not None else communicator.current()
        self.params, self.cfg, self.env, self.model, self.device = params, cfg, env, model, device
        self.run, self.logger, self.seed, self.raw_config = run, logger, seed, raw_config
        self.num_envs = env.num_envs
        self.env_spec = env_spec(env)  # the env's agents, groups, tensor stepping ... (envs/spec.py)
        self.num_agents = self.env_spec.num_agents  # rows per env (rl_games' algo.num_agents)
        if hasattr(cfg, "minibatch_size"):  # the batch counts the env's agents (multi-agent envs)
            check_batch(cfg, params.source, self.num_agents)
        self.tracker = EpisodeTracker(self.num_envs, cfg.games_to_track, device, cfg.success_mode)
        self.success = SuccessReader(cfg.success_key)
        self.info_means = InfoMeans(cfg.log_info_keys)
        self.epoch = 0
        self.frames = 0
        self.best_reward = -math.inf
        self.obs: torch.Tensor | None = None
        self.events = CallbackList([load_callback(name) for name in cfg.callbacks])
        self.events.bind(self)  # callbacks get a CallbackContext of this run
        self.last_stats: dict[str, float] = {}  # the last epoch's metrics and episode means (TrainingState)
        self.last_episodes: dict[str, float] | None = None
        self.started = time.time()  # when train() started
        self._closed = False
        if self.env_spec.stats:  # backend counters (Ray: env/dropped_episodes)
            self.events.add(EnvStatsCallback())
        if cfg.evaluation.interval > 0:
            self.events.add(EvaluationCallback(cfg.evaluation, lambda n, s: build_env(params, n, s)))
        if getattr(cfg, "self_play_config", None) is not None and self.env_self_play:
            self.events.add(SelfPlayCallback(cfg.self_play_config, env, params.source))
        if getattr(cfg, "hyperparam_schedule", None):  # a replayed PBT schedule, through set_params
            check_names(cfg.hyperparam_schedule, self.tunable, params.algo.name, params.source)
            self.events.add(HyperparamSchedule(cfg.hyperparam_schedule))
        self.tensor_env = self.env_spec.tensor_native
        self.signals: StopSignals | None = None
        self.agent: Any = None
        self.world_size = self.comm.world_size  # processes training together; frame counters count all of them
        self.threads: ThreadPlan | None = None  # CPU threads per phase, set by the Runner
        self.divergence: DivergenceGuard | None = None  # the algorithm's, once it built its agent
        self._init_live_params()

    # ----- the loop -------------------------------------------------------------------------
    def train(self) -> TrainResult:
        """Train until max_epochs, max_frames, score_to_win or a stop signal; returns the statistics.

        SIGINT/SIGTERM stop after the current env step with a checkpoint of the last completed
        epoch; an env failure does the same, then raises EnvError; a NaN/inf stops (or rolls back,
        with ``divergence.action: rollback``) without ever saving non-finite parameters.
        """
        start = self.started = time.time()
        stop = None
        with StopSignals() as signals:
            self.signals = signals
            self.obs = self._reset_envs()
            self._snapshot()
            self.events.emit("on_train_start")
            while stop is None:
                self._apply_pending_params()
                t0 = time.time()
                try:
                    if not self._guarded_collect():
                        stop = signals.stop_reason()
                        break
                    self.events.emit("on_rollout_end")
                    t1 = time.time()
                    stats = self._guarded_update()
                except DivergenceError as exc:
                    self._diverged(exc)
                    continue  # rolled back: collect afresh with the restored learner
                if stats is None:
                    continue
                self.epoch += 1
                rollout_s, update_s = self.epoch_seconds(t1 - t0, time.time() - t1)
                if self.info_means.keys:
                    stats = {**stats, **self.info_means.pop()}
                episodes = self._episode_stats()
                self._log(stats, episodes, rollout_s, update_s)
                self._checkpoints(episodes)
                if self.snapshot_due():
                    self._snapshot()
                self.last_stats, self.last_episodes = stats, episodes
                self.events.emit("on_epoch_end", stats, episodes)
                stop = self._stop_reason(episodes)
            last = self.save("last")
        return self._finish(stop, start, last)

    def _guarded_collect(self) -> bool:
        """:meth:`collect`; an env failure saves the last completed epoch, then raises EnvError."""
        try:
            return self.collect()
        except (EnvError, DivergenceError, KeyboardInterrupt):
            raise
        except Exception as exc:
            path = self.save("last")
            saved = f"; last completed epoch {self.epoch} saved to {path}" if path else ""
            raise EnvError(f"env step failed at epoch {self.epoch + 1}: {describe(exc)}{saved}") from exc

    def _guarded_update(self) -> dict[str, float] | None:
        """:meth:`update` under the update's thread count; non-finite parameters after it diverge."""
        with self.update_phase():
            stats = self.update()
        if stats is None:
            return None
        bad = check_parameters(self.model)
        if bad is not None:
            raise DivergenceError(f"{bad} became non-finite in the update")
        return stats

    def _diverged(self, exc: DivergenceError) -> None:
        """A NaN/inf: roll back to the last snapshot and restart the envs' episodes (``divergence.action:
        rollback``, within max_rollbacks), else save what is finite and raise naming the epoch."""
        if self.divergence is None:
            raise exc
        try:
            self.divergence.handle(exc, self.epoch)
        except DivergenceError:
            self.save("last")  # the restored, finite parameters (a non-finite model is never saved)
            raise
        self.restart_episodes()

    def _snapshot(self) -> None:
        if self.divergence is not None:
            self.divergence.snapshot(self.epoch)

    # ----- the algorithm's hooks (rlchain.training.algorithm.Algorithm) -------------------------
    def collect(self) -> bool:  # pragma: no cover - every algorithm implements it
        """One epoch of env steps; False when a stop signal came."""
        raise NotImplementedError

    def update(self) -> dict[str, float] | None:  # pragma: no cover - every algorithm implements it
        """Learn from the collected epoch, count its frames; metrics, or None after a rollback."""
        raise NotImplementedError

    def frames_per_epoch(self) -> int:  # pragma: no cover - every algorithm implements it
        """Env frames one epoch adds."""
        raise NotImplementedError

    def epoch_seconds(self, collect_s: float, update_s: float) -> tuple[float, float]:
        """(rollout, update) seconds of the epoch from the time spent in collect and in update."""
        return collect_s, update_s

    def _progress(self, epoch_frames: int | None = None) -> float:
        """Training progress in [0, 1] at the end of this epoch, for the schedules: epochs/max_epochs,
        else frames/max_frames (``epoch_frames``: this epoch's frames, default :meth:`frames_per_epoch`)."""
        cfg = self.cfg
        if cfg.max_epochs > 0:
            return (self.epoch + 1) / cfg.max_epochs
        if cfg.max_frames > 0:
            added = self.frames_per_epoch() if epoch_frames is None else epoch_frames
            return (self.frames + added) / cfg.max_frames
        return 0.0

    def snapshot_due(self) -> bool:
        """Whether the divergence guard snapshots the learner after this epoch (default: every epoch)."""
        return True

    def restart_episodes(self) -> None:
        """After a rollback: every env starts a fresh episode."""
        self.tracker.reset_running()
        self.obs = self._reset_envs()

    # ----- loop helpers ---------------------------------------------------------------------
    def update_phase(self) -> AbstractContextManager:
        """Context for the gradient updates: ``update_threads`` CPU threads while the envs are idle."""
        return self.threads.update_phase() if self.threads is not None else nullcontext()

    def close(self) -> None:
        """Close what the run opened besides the training env (the evaluation env, callbacks'
        resources): once, on every exit path. The training env belongs to whoever built it."""
        if self._closed:
            return
        self._closed = True
        self.events.close()

    @classmethod
    def create(cls, *args: Any, **kwargs: Any) -> Loop:
        """``cls(*args, **kwargs)``, but a constructor that fails half-way (a config error, a replay
        buffer too big for memory) first closes what it had opened (the evaluation env)."""
        trainer = cls.__new__(cls)
        try:
            trainer.__init__(*args, **kwargs)
        except BaseException:
            if isinstance(getattr(trainer, "events", None), CallbackList):
                trainer.events.close()
            raise
        return trainer

    def request_stop(self, reason: str) -> None:
        """Stop after the current epoch with a checkpoint, as a signal would (for callbacks)."""
        if self.signals is not None:
            self.signals.request(reason)

    def _reset_envs(self) -> torch.Tensor:
        try:
            obs = self.env.reset(seed=self.seed + self.epoch)
        except Exception as exc:
            raise EnvError(f"env reset failed: {describe(exc)}") from exc
        check_obs_shape(obs, self.num_envs, self.env.observation_space, "env reset")
        return self._to_tensor(obs)

    def learners(self) -> list[tuple[torch.nn.Module, Any]]:
        """(model, agent) pairs that train: every rank starts from rank 0's (:meth:`join_ranks`)."""
        return [(self.model, self.agent)]

    def join_ranks(self) -> None:
        """Under torchrun, once the run is built (and resumed): every rank takes rank 0's parameters,
        buffers and optimizer state; after a resume, which restored rank 0's RNG state everywhere,
        the other ranks reseed their own streams."""
        if not self.comm.active:
            return
        for model, agent in self.learners():
            self.comm.broadcast_learner(model, agent)
        if self.epoch > 0 and not self.comm.is_main:
            seed_everything(self.comm.rank_seed + self.epoch)

    def _episode_stats(self) -> dict[str, float] | None:
        """Mean reward and length of the tracked games; under torchrun over every rank's games, so
        all ranks log, save and stop alike."""
        return self.comm.episode_stats(self.tracker)

    def _checkpoints(self, episodes: dict | None) -> None:
        """Best checkpoint on a new best mean reward (after save_best_after), periodic ones."""
        cfg = self.cfg
        if episodes is not None and episodes["reward"] > self.best_reward:
            self.best_reward = episodes["reward"]
            if self.epoch >= cfg.save_best_after and cfg.evaluation.select_best == "training":
                self.save("best")
        if cfg.save_frequency > 0 and self.epoch % cfg.save_frequency == 0:
            self.save(f"ep_{self.epoch}")
            self.save("last")

    def _stop_reason(self, episodes: dict | None) -> str | None:
        cfg = self.cfg
        if episodes is not None and episodes["reward"] >= cfg.score_to_win:
            return f"score_to_win {cfg.score_to_win} reached"
        if episodes is not None and episodes.get("success", -1.0) >= cfg.success_to_win:
            return f"success_to_win {cfg.success_to_win} reached"
        if cfg.max_epochs > 0 and self.epoch >= cfg.max_epochs:
            return f"max_epochs {cfg.max_epochs} reached"
        if cfg.max_frames > 0 and self.frames >= cfg.max_frames:
            return f"max_frames {cfg.max_frames} reached"
        if self.signals is not None and self.signals.requested:
            return self.signals.stop_reason()
        return None

    def _finish(self, stop: str, start: float, last: str | None) -> TrainResult:
        """Report the stop, emit on_train_end and build the result."""
        self.logger.flush()
        mean = self.tracker.mean_return() if self.tracker.has_data else float("nan")
        if self.cfg.print_stats or stop.startswith("interrupted"):
            success = f", success rate {self.tracker.success_rate():.2f}" if self.tracker.has_success else ""
            head = stop if stop.startswith("stopped") else f"stopped: {stop}"  # not 'stopped: stopped by ...'
            log.info(f"{head} at epoch {self.epoch}, frames {self.frames}, mean reward "
                     f"{mean:.2f}, best {self.best_reward:.2f}{success}")
        if stop.startswith("interrupted") and last:
            log.info(f"resume with: python runner.py --train --file <config> --checkpoint {last}")
        result = TrainResult(self.epoch, self.frames, mean, self.best_reward, stop,
                             self.run.root if self.run else "", time.time() - start)
        self.events.emit("on_train_end", result)
        return result

    def _log(self, stats: dict[str, float], episodes: dict | None, rollout_s: float, update_s: float) -> None:
        """The epoch's TensorBoard scalars and console line: the metrics under :attr:`metric_tags`."""
        timing = {"batch": self.frames_per_epoch(), "rollout": rollout_s, "update": update_s}
        console = [fmt.format(stats[name]) for name, fmt in self.console_fields if name in stats]
        self.logger.epoch(self.epoch, self.cfg.max_epochs, self.frames, tag_metrics(stats, self.metric_tags),
                          episodes, self.best_reward, timing, console)

    def _to_tensor(self, x: Any) -> torch.Tensor:
        return to_device(x, self.device)

    def _env_outcome(self, result: Any, rows: slice = slice(None)
                     ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """A step's (rewards, terminated, truncated, dones) as device tensors; finished episodes are
        recorded as whole games (Atari lives), episodes cut by a dead Ray worker are dropped.
        ``rows``: the envs ``result`` is for (a pipelined rollout's env group; all by default)."""
        rewards = self._to_tensor(result.reward).float()
        terminated = self._to_tensor(result.terminated).bool()
        truncated = self._to_tensor(result.truncated).bool()
        dones = terminated | truncated
        success = self.success.read(result.infos, dones)
        if self.info_means.keys:
            self.info_means.add(result.infos)
        self.tracker.step(*game_outcome(result, rewards, dones), dropped=dropped_rows(result), rows=rows,
                          success=success)
        if self.events.step_callbacks:  # nothing more per step unless a callback asked for steps
            self._emit_env_step(result, dones, rows)
        return rewards, terminated, truncated, dones

    def _emit_env_step(self, result: Any, dones: torch.Tensor, rows: slice) -> None:
        """``on_env_step`` with the rows of ``result`` whose episode ended (one per env: its first
        agent's row); episodes a dead Ray worker cut did not end."""
        lost = dropped_rows(result)
        if lost is not None:
            dones = dones & ~torch.as_tensor(lost, device=dones.device).bool().reshape(-1)
        done_indices = dones.nonzero().squeeze(-1)
        if self.num_agents > 1:
            done_indices = done_indices[done_indices % self.num_agents == 0]
        self.events.emit_env_step(result, done_indices, rows)

    def _env_actions(self, actions: torch.Tensor) -> Any:
        """Tensor envs (``env.is_tensor_env``) take device tensors; numpy backends take arrays."""
        return actions if self.tensor_env else actions.cpu().numpy()


def tag_metrics(stats: dict[str, float], tags: dict[str, str]) -> dict[str, float]:
    """``{tag: value}`` of the metrics ``tags`` names, plus those whose name already is a tag
    (``losses/aux_l2``); other metrics (counts, internal values) are for callbacks only."""
    out = {}
    for name, value in stats.items():
        tag = tags.get(name, name if "/" in name else None)
        if tag is not None:
            out[tag] = float(value)
    return out


def to_device(x: Any, device: torch.device) -> torch.Tensor:
    """``x`` (numpy array, tensor, ...) as a tensor on ``device``: the one conversion per env step.

    A numpy array bound for CUDA goes through page-locked (pinned) host memory and an asynchronous
    copy, so the transfer does not stage through pageable memory; torch's caching host allocator
    reuses the pinned blocks once their copy is done. On CPU the array is shared, not copied.
    """
    if device.type == "cuda" and isinstance(x, np.ndarray) and x.dtype != np.object_:
        x = np.ascontiguousarray(x) if x.flags.writeable else np.array(x)  # from_numpy wants writable
        host = torch.from_numpy(x)
        return host.pin_memory().to(device, non_blocking=True)
    return torch.as_tensor(x, device=device)


def describe(exc: BaseException) -> str:
    """``Type: message`` on one line."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__

