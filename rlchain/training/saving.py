"""When and what the Loop saves: what a checkpoint holds (:meth:`CheckpointSaver.state_dict`), when one is
written (:meth:`~CheckpointSaver.after_epoch`: best and periodic), writing it (:meth:`~CheckpointSaver.save`) and
resuming from it (:meth:`~CheckpointSaver.restore`). The file itself (atomic writes, reading, its errors) is
:mod:`rlchain.runs.checkpoint`'s.
"""

from __future__ import annotations

import math
from typing import Any, Protocol, runtime_checkable

from rlchain.algos.base.algorithm import Algorithm
from rlchain.algos.base.context import RunContext
from rlchain.algos.base.safety import check_parameters
from rlchain.config.resolve import CONFIG_FORMAT, config_state
from rlchain.log import get_logger
from rlchain.runs import checkpoint as ckpt
from rlchain.runs import rl_games_checkpoint, rl_games_layout
from rlchain.runs.run_dir import RunDir
from rlchain.training.events import CallbackList
from rlchain.training.resume import ResumePoint, check_run_state
from rlchain.version import __version__

log = get_logger(__name__)


@runtime_checkable
class CheckpointState(Protocol):
    """Optional part of an :class:`~rlchain.algos.base.algorithm.Algorithm`: what its checkpoints carry beyond
    the model, the agent and the counters (PPO: the central value, RND; SAC: the replay buffer)."""

    def extra_state(self, kind: str) -> dict[str, Any]:
        """What a checkpoint of ``kind`` (best, last, ep_N) carries beyond the model, the agent and the counters."""
        ...

    def restore_extra(self, state: dict[str, Any]) -> None:
        """Restore what :meth:`extra_state` added."""
        ...

class CheckpointSaver:
    """The checkpoints of one run: the algorithm's model, agent and extra state plus the run's counters."""

    def __init__(self, ctx: RunContext, algorithm: Algorithm, run: RunDir | None, events: CallbackList) -> None:
        self.ctx, self.algorithm, self.run, self.events = ctx, algorithm, run, events
        self.best_reward = -math.inf
        self.last_reward: float | None = None  # the last epoch's mean reward (rl_games' final file name)
        self.point = ResumePoint(ctx, algorithm)  # the last epoch boundary: RNG, envs, episodes in progress
        self.newest: tuple[str, int] | None = None  # (path, epoch) of the newest checkpoint this run wrote
        self.resumed_from: str | None = None  # the checkpoint this run started from
        self.failure: str | None = None  # why the latest write failed (None once one succeeds)
        self.failed_writes = 0  # checkpoint writes that failed in this run
        self.frames_seen = ctx.frames  # frames at the last periodic check (save_frequency_frames)

    def state_dict(self, kind: str = "last") -> dict[str, Any]:
        """Everything exact resume needs: the learner now and the run's state at the last epoch
        boundary (the same moment unless a stop signal or an env error came during an epoch's collect)."""
        ctx, algo = self.ctx, self.algorithm
        params = ctx.params
        boundary = self.point.state()
        state = {
            "format": ckpt.FORMAT, "algo": params.algo.name, "model_name": params.model.name,
            "config": config_state(params, {"seed": ctx.seed, "device": str(ctx.device),  # the run context
                                            "rank": int(getattr(ctx.comm, "rank", 0)),
                                            "world_size": ctx.world_size, "print_stats": ctx.cfg.print_stats}),
            "config_format": CONFIG_FORMAT, "live_config": dict(ctx.live_config),
            "model": algo.model.state_dict(), "agent": algo.agent.state_dict(),
            "epoch": ctx.epoch, "frames": boundary["frames"], "best_reward": self.best_reward,
            "episodes": boundary["episodes"], "rng": boundary["rng"], "run_state": boundary["run_state"],
            "seed": ctx.seed, "version": __version__,
        }
        if "ranks" in boundary:  # torchrun: each rank's RNG, episodes and envs, in rank order
            state["ranks"] = boundary["ranks"]
        if isinstance(algo, CheckpointState):
            state.update(algo.extra_state(kind))
        if getattr(algo.model, ckpt.NORMS_DROPPED, False):  # the config's normalization was not built: reload so
            state[ckpt.NORMS_DROPPED] = True
        if self.run is not None and self.run.layout == "embodichain":
            state.update(embodichain_keys(state))
        get_env_state = getattr(ctx.env, "get_env_state", None)  # optional (rl_games' IVecEnv): a curriculum
        env_state = get_env_state() if callable(get_env_state) else None
        if env_state is not None:
            state["env_state"] = env_state
        if self.run is not None and self.run.layout == "rl_games":
            state = rl_games_layout.rl_games_keys(state)
        return state

    def save(self, kind: str) -> str | None:
        """Write a checkpoint; a failed write is reported and training keeps the previous one."""
        if self.run is None:
            return None
        if kind == "last" and self.run.layout == "rl_games":
            kind = "file:" + rl_games_layout.final_stem(self.ctx.params.config.name, self.ctx.epoch, self.last_reward)
        if kind == "last" and self.run.layout == "embodichain":  # theirs: periodic and final files alike
            kind = f"file:{self.ctx.params.config.name}_step_{self.ctx.frames}"
        bad = check_parameters(self.algorithm.model)
        if bad is not None:
            log.warning(f"warning: not saving the {kind} checkpoint: {bad} is not finite")
            return None
        path = self.run.checkpoint(kind)
        state = self.state_dict(kind)
        try:
            ckpt.save_atomic(state, path)
        except Exception as exc:  # storage faults of any type: OSError, torch's zip writer's RuntimeError, ...
            first = self.failure is None  # one line per run of failures (a full disk fails every write after)
            self.failure = f"writing {path} failed: {storage_error(exc)}"
            self.failed_writes += 1
            if first:
                log.warning(f"warning: checkpoint {self.failure}; {self.kept()}; training goes on (the checkpoint "
                            f"writes that fail after this are counted at the end, not each reported)")
            return None
        self.failure = None
        self.newest = (path, self.ctx.epoch)
        self.events.emit("on_checkpoint", path, kind)
        return path

    def failures_line(self) -> str | None:
        """The count of failed checkpoint writes, for the end of the run (None when at most one failed: its
        warning said it)."""
        if self.failed_writes < 2:
            return None
        now = f"the last one: {self.failure}" if self.failure else "the last write succeeded"
        return f"warning: {self.failed_writes} checkpoint writes failed in this run ({now}); {self.kept()}"

    def kept(self) -> str:
        """What is on disk to resume from, in words (for a failed write and the stop line)."""
        if self.newest is not None:
            return f"the newest checkpoint is {self.newest[0]} (epoch {self.newest[1]})"
        if self.resumed_from is not None:
            return f"this run wrote no checkpoint; the one it resumed from is {self.resumed_from}"
        return "no checkpoint of this run exists"

    def after_epoch(self, episodes: dict | None) -> None:
        """Best checkpoint on a new best mean reward (after save_best_after), periodic ones."""
        cfg, epoch = self.ctx.cfg, self.ctx.epoch
        if episodes is not None:
            self.last_reward = float(episodes["reward"])
        rl_games = self.run is not None and self.run.layout == "rl_games"
        # rl_games: the periodic file once games have finished, before the best one (and no other periodic file)
        if rl_games and episodes is not None and cfg.save_frequency > 0 and epoch % cfg.save_frequency == 0:
            self.save("file:" + rl_games_layout.periodic_stem(cfg.name, epoch, episodes["reward"]))
        if episodes is not None and episodes["reward"] > self.best_reward:
            self.best_reward = episodes["reward"]
            if epoch >= cfg.save_best_after and cfg.evaluation.select_best == "training":
                self.save("best")
        if not rl_games and self._periodic_due():
            if self.run is None or self.run.layout != "embodichain":
                self.save(f"ep_{epoch}")
            self.save("last")

    def _periodic_due(self) -> bool:
        """Whether this epoch writes the periodic checkpoint: every ``save_frequency`` epochs, or at the first
        epoch end at or past each multiple of ``save_frequency_frames`` (EmbodiChain's save_freq rule)."""
        cfg = self.ctx.cfg
        seen, self.frames_seen = self.frames_seen, self.ctx.frames
        if cfg.save_frequency > 0 and self.ctx.epoch % cfg.save_frequency == 0:
            return True
        every = cfg.save_frequency_frames
        return every > 0 and self.ctx.frames // every > seen // every

    def _from_rl_games(self, state: dict[str, Any], path: str) -> dict[str, Any]:
        """A converted rl_games checkpoint completed for resume: its optimizer state (PPO's one, SAC's three) on
        this agent's parameters and its learning rate; this run's RNG streams and episode statistics (rl_games keeps
        none), so the envs start new episodes."""
        algo = self.algorithm
        cv_agent = getattr(algo, "cv_agent", None)  # PPO's central value, its file's optimizer put on it
        cv = cv_agent is not None and "central_value" in state
        try:
            agent, cv_state = rl_games_checkpoint.resume_agent_states(
                state, algo.agent.state_dict(), _trainable_names(algo.model),
                cv_agent.state_dict() if cv else None, _trainable_names(algo.central_value) if cv else None)
        except ValueError as exc:
            raise ckpt.CheckpointError(f"{path}: {exc}") from None
        if cv_state is not None:
            state = {**state, "central_value_agent": cv_state}
        if state.get("rl_games_unread"):
            log.warning(f"warning: {path}: rl_games' {', '.join(state['rl_games_unread'])} not read (rlchain starts "
                        f"them anew)")
        run_state = {**self.point._no_run_state(), "env_missing": "an rl_games checkpoint keeps none"}
        return {**state, "agent": agent, "episodes": self.ctx.tracker.state_dict(), "rng": ckpt.rng_state(),
                "run_state": run_state, "live_config": {}}

    def restore(self, state: dict[str, Any], path: str, weights: bool = True) -> None:
        """Continue from a checkpoint: weights (``weights``: False when the model holds them already),
        optimizer(s), lr, normalizers, counters, RNG, and (at the algorithm's ``start``) the envs' state and
        episodes in progress when the checkpoint has them."""
        ctx, algo = self.ctx, self.algorithm
        name = ctx.params.algo.name
        state = ckpt.own_state(state)  # one written under rl_games' API (get_full_state_weights too)
        if state.get("origin") == rl_games_checkpoint.ORIGIN:
            state = self._from_rl_games(state, path)
        check_run_state(state, path)
        if state.get("algo") not in (None, name):
            raise ckpt.CheckpointError(f"{path}: checkpoint was trained with algo '{state['algo']}', "
                                       f"the config says '{name}'")
        if weights:
            ckpt.load_model_state(algo.model, state, path)
        self.resumed_from = path
        algo.agent.load_state_dict(state["agent"])
        ctx.epoch, ctx.frames = int(state["epoch"]), int(state["frames"])
        for key, value in state.get("live_config", {}).items():  # values set_params gave the config fields
            if key in algo.tunable:
                algo.apply_hyperparam(key, value)
        self.best_reward = float(state["best_reward"])
        ctx.tracker.load_state_dict(state["episodes"])
        if isinstance(algo, CheckpointState):
            algo.restore_extra(state)
        self.point.restore(state)
        self.frames_seen = ctx.frames
        set_env_state = getattr(ctx.env, "set_env_state", None)
        if "env_state" in state and callable(set_env_state):
            set_env_state(state["env_state"])

    def restart_episodes(self) -> None:
        """After a rollback or a checkpoint loaded into the running envs (PBT's exploit): every env starts
        a fresh episode (a loaded checkpoint's env state is not used), which is the new epoch boundary."""
        self.ctx.resume_state = None
        self.algorithm.restart_episodes()
        self.point.capture(gather=False)  # no collective: under torchrun a rank may roll back alone


def embodichain_keys(state: dict[str, Any]) -> dict[str, Any]:
    """The keys EmbodiChain's trainer writes, beside rlchain's (the same tensors, stored once): ``global_step``
    (env steps over all ranks), ``policy`` (rlchain's model state dict: rlchain's module names, not
    EmbodiChain's), ``optimizer`` when the algorithm has one."""
    out = {"global_step": int(state["frames"]), "policy": state["model"]}
    agent = state.get("agent")
    if isinstance(agent, dict) and "optimizer" in agent:
        out["optimizer"] = agent["optimizer"]
    return out


def storage_error(exc: BaseException) -> str:
    """A failed write in words on one line: the OS's reason, else the type and message (torch's zip writer
    raises RuntimeError('... unexpected pos ...') on a full disk)."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    text = " ".join(str(exc).split())[:200]
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _trainable_names(model: Any) -> list[str]:
    """The names of ``model``'s trainable parameters, in order (an optimizer's parameter order)."""
    return [name for name, p in model.named_parameters() if p.requires_grad]
