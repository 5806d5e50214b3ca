"""What an algorithm gets from the run: a :class:`RunContext` the training loop builds and hands it.

The loop (:class:`rlchain.training.loop.Loop`) owns the run -- counters, stop signals, events, the
episode statistics; an algorithm reads and advances them through this object, never through a base
class. It lives below ``training/`` so algorithms and the loop can both import it.
"""

from __future__ import annotations

import dataclasses
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import torch

from rlchain.algos.base.episodes import AgentEpisodes, EpisodeTracker
from rlchain.algos.base.safety import StopSignals
from rlchain.algos.core.collector import StepOutcome
from rlchain.config.params import Params
from rlchain.envs.obs_dict import ObsDict
from rlchain.envs.spec import EnvSpec, check_obs_shape, env_spec
from rlchain.envs.vecenv import VecEnv, dropped_rows, game_outcome
from rlchain.envs.wrappers.info_means import InfoMeans
from rlchain.envs.wrappers.success import SuccessReader
from rlchain.errors import EnvError
from rlchain.parallel.communicator import Communicator
from rlchain.parallel.threads import ThreadPlan


class ScalarLogger(Protocol):
    """The run's log (rlchain.runs.logging.TrainLogger): what an algorithm may write to it."""

    start: float

    def scalar(self, tag: str, value: float, step: int) -> None: ...


class StepEvents(Protocol):
    """The run's callbacks (rlchain.training.events.CallbackList), as far as an env step concerns them."""

    step_callbacks: list

    def emit_env_step(self, result: Any, done_indices: torch.Tensor, rows: slice) -> None: ...


@dataclass(eq=False)
class RunContext:
    """The run an algorithm trains in: its env, device, counters, episode statistics, stop signals.

    ``cfg`` is the run's config; population-based training replaces it with a changed copy
    (:meth:`replace_config`), so read it here (or from the algorithm's own ``cfg``), not from ``params``.
    """

    params: Params
    cfg: Any
    env: VecEnv
    device: torch.device
    seed: int
    comm: Communicator
    logger: ScalarLogger
    events: StepEvents
    tracker: Any  # an EpisodeTracker (multi-policy: every agent's AgentEpisodes)
    success: SuccessReader
    info_means: InfoMeans
    spec: EnvSpec
    epoch: int = 0
    """Epochs completed (the loop counts them)."""
    frames: int = 0
    """Env frames so far over all ranks (the Loop counts an epoch's after its update; an algorithm that
    ``counts_frames_while_collecting`` counts them itself)."""
    signals: StopSignals | None = None
    threads: ThreadPlan | None = None
    live_config: dict[str, Any] = field(default_factory=dict)
    """Tunable config fields changed during the run (set_params); checkpointed."""
    resuming: bool = False
    """The run continues from a checkpoint whose weights the model already holds (the Runner loaded them
    before building the algorithm): an algorithm loads no other weights into it (PPO's distilled student)."""
    resume_state: dict[str, Any] | None = None
    """After a restore from a checkpoint holding the envs' state: that state and the algorithm's
    position in its episodes, until :meth:`resume_envs` puts them back (the algorithm's ``start``)."""
    num_envs: int = field(init=False)
    """Envs of the training env."""
    num_agents: int = field(init=False)
    """Rows per env (rl_games' ``algo.num_agents``)."""
    world_size: int = field(init=False)
    """Processes training together (torchrun); frame counters count all of them."""

    def __post_init__(self) -> None:  # the run's fixed sizes, read from the env, its spec and the ranks once
        self.num_envs, self.num_agents, self.world_size = self.env.num_envs, self.spec.num_agents, self.comm.world_size

    def stop_requested(self) -> bool:
        """Whether a stop signal (SIGINT/SIGTERM, a callback's request) came: end the epoch early."""
        return self.signals is not None and self.signals.requested

    def update_phase(self) -> AbstractContextManager:
        """Context for gradient updates: ``update_threads`` CPU threads while the envs are idle."""
        return self.threads.update_phase() if self.threads is not None else nullcontext()

    def progress(self, epoch_frames: int) -> float:
        """Training progress in [0, 1] at the end of this epoch, for the schedules: epochs/max_epochs,
        else frames/max_frames (``epoch_frames``: the frames this epoch adds)."""
        cfg = self.cfg
        if cfg.max_epochs > 0:
            return (self.epoch + 1) / cfg.max_epochs
        if cfg.max_frames > 0:
            return (self.frames + epoch_frames) / cfg.max_frames
        return 0.0

    def replace_config(self, name: str, value: Any) -> tuple[Any, Any]:
        """Set config field ``name`` (keeping its type) for the rest of the run; (old cfg, new cfg).
        The parsed config is frozen: the run goes on with a copy holding the new value."""
        current = getattr(self.cfg, name)
        value = type(current)(value) if current is not None else value
        self.live_config[name] = value
        old, self.cfg = self.cfg, dataclasses.replace(self.cfg, **{name: value})
        return old, self.cfg

    # ----- the env ---------------------------------------------------------------------------
    def reset_envs(self) -> torch.Tensor:
        """Reset every env (seeded by the epoch); the first observations as a device tensor."""
        obs = self.reset_raw()
        check_obs_shape(obs, self.num_envs, self.env.observation_space, "env reset")
        return self.to_tensor(obs)

    def resume_envs(self) -> dict[str, Any] | None:
        """At ``start`` after a restore that carried the envs' state (``resume_state``): put the envs and
        the episodes in progress back and return the algorithm's saved position (its observations, RNN
        states) for its ``load_position``; None otherwise (then the algorithm resets the envs)."""
        pending, self.resume_state = self.resume_state, None
        if pending is None:
            return None
        try:
            self.env.set_state(pending["env"])
        except Exception as exc:
            raise EnvError(f"restoring the env state from the checkpoint failed: {describe(exc)}") from exc
        self.tracker.load_running_state(pending["running"])
        return pending["position"]

    def reset_raw(self) -> Any:
        """``env.reset`` as the env returns it (per-agent dicts of a multi-policy env); EnvError on failure."""
        try:
            return self.env.reset(seed=self.seed + self.epoch)
        except Exception as exc:
            raise EnvError(f"env reset failed: {describe(exc)}") from exc

    def to_tensor(self, x: Any) -> torch.Tensor:
        """``x`` as a tensor on the training device (:func:`to_device`)."""
        return to_device(x, self.device)

    def record_step(self, result: Any, rows: slice = slice(None)) -> StepOutcome:
        """Record an env step in the run -- episode statistics (finished episodes as whole games: Atari
        lives; episodes cut by a dead Ray worker dropped), task success, info means, ``on_env_step``
        callbacks -- and return its (rewards, terminated, truncated, dones) as device tensors (a StepOutcome).
        ``rows``: the envs ``result`` is for (a pipelined rollout's env group; all by default)."""
        host = self._host_outcome(result, rows)
        if host is not None:
            return self._record_host_step(result, rows, *host)
        rewards, terminated, truncated, dones = self.step_outcome(result)
        success = self.success.read(result.infos, dones)
        if self.info_means.keys:
            self.info_means.add(result.infos)
        self.tracker.step(*game_outcome(result, rewards, dones), dropped=dropped_rows(result), rows=rows,
                          success=success)
        if self.events.step_callbacks:  # nothing more per step unless a callback asked for steps
            self.emit_env_step(result, dones, rows)
        return StepOutcome(rewards, terminated, truncated, dones)

    def _host_outcome(self, result: Any, rows: slice) -> tuple[np.ndarray, ...] | None:
        """(rewards float32, terminated, truncated, dones) of a step as numpy arrays when the step can be recorded
        in numpy (:meth:`_record_host_step`): a CPU run, an env giving (N,) numpy arrays, whole episodes (no
        ``game_reward`` / ``game_over``), the plain EpisodeTracker; else None (the tensor path)."""
        reward, terminated, truncated = result.reward, result.terminated, result.truncated
        if (self.device.type != "cpu" or type(reward) is not np.ndarray or type(terminated) is not np.ndarray
                or type(truncated) is not np.ndarray or reward.ndim != 1 or not isinstance(rows, slice)
                or type(self.tracker).step is not EpisodeTracker.step or not self.tracker.on_host
                or getattr(result, "game_reward", None) is not None or getattr(result, "game_over", None) is not None):
            return None
        # the casts of step_outcome's .float() / .bool(), in numpy (the same values)
        reward = reward if reward.dtype == np.float32 else reward.astype(np.float32)
        terminated = terminated if terminated.dtype == np.bool_ else terminated.astype(bool)
        truncated = truncated if truncated.dtype == np.bool_ else truncated.astype(bool)
        return reward, terminated, truncated, terminated | truncated

    def _record_host_step(self, result: Any, rows: slice, rewards: np.ndarray, terminated: np.ndarray,
                          truncated: np.ndarray, dones: np.ndarray) -> StepOutcome:
        """:meth:`record_step` of a CPU run in numpy: on a batch of a few envs each torch op costs a few
        microseconds of dispatch, numpy's a fraction of that. The same statistics, events and outcome; the
        outcome's tensors share the arrays' memory, as ``torch.as_tensor`` does."""
        success = self.success.read(result.infos, dones)
        if self.info_means.keys:
            self.info_means.add(result.infos)
        self.tracker.host_step(rewards, dones, dropped=dropped_rows(result), rows=rows, success=success)
        if self.events.step_callbacks:
            lost = dropped_rows(result)
            ended = dones if lost is None else dones & ~np.asarray(lost).astype(bool).reshape(-1)
            done_indices = torch.from_numpy(np.flatnonzero(ended))
            if self.num_agents > 1:
                done_indices = done_indices[done_indices % self.num_agents == 0]
            self.events.emit_env_step(result, done_indices, rows)
        return StepOutcome(torch.from_numpy(rewards), torch.from_numpy(terminated), torch.from_numpy(truncated),
                           torch.from_numpy(dones))

    def step_outcome(self, result: Any, rows: slice = slice(None)) -> StepOutcome:
        """An env step's (rewards, terminated, truncated, dones) as device tensors, recorded nowhere (steps
        outside training: a value warm start before the first epoch)."""
        rewards = self.to_tensor(result.reward).float()
        terminated = self.to_tensor(result.terminated).bool()
        truncated = self.to_tensor(result.truncated).bool()
        return StepOutcome(rewards, terminated, truncated, terminated | truncated)

    env_outcome = record_step  # the same method, for user algorithms that call it by this name

    def emit_env_step(self, result: Any, dones: torch.Tensor, rows: slice) -> None:
        """``on_env_step`` with the rows of ``result`` whose episode ended (one per env: its first
        agent's row); episodes a dead Ray worker cut did not end."""
        lost = dropped_rows(result)
        if lost is not None:
            dones = dones & ~torch.as_tensor(lost, device=dones.device).bool().reshape(-1)
        done_indices = dones.nonzero().squeeze(-1)
        if self.num_agents > 1:
            done_indices = done_indices[done_indices % self.num_agents == 0]
        self.events.emit_env_step(result, done_indices, rows)


def make_context(params: Params, env: VecEnv, device: torch.device, seed: int, comm: Communicator,
                 logger: ScalarLogger, events: StepEvents, threads: ThreadPlan | None = None,
                 resuming: bool = False) -> RunContext:
    """The context of a fresh run on ``env``: counters at zero, episode statistics empty."""
    cfg = params.config
    if getattr(params, "policies", None) is not None:  # multi-policy PPO: every agent's episodes, agent-major rows
        tracker = AgentEpisodes(env.num_envs * len(env.agent_ids), cfg.games_to_track, device)
    else:
        tracker = EpisodeTracker(env.num_envs, cfg.games_to_track, device, cfg.success_mode)
    return RunContext(params=params, cfg=cfg, env=env, device=device, seed=seed, comm=comm, logger=logger,
                      events=events, tracker=tracker,
                      success=SuccessReader(cfg.success_key), info_means=InfoMeans(cfg.log_info_keys),
                      spec=env_spec(env), threads=threads, resuming=resuming)


def to_device(x: Any, device: torch.device) -> torch.Tensor:
    """``x`` (numpy array, tensor, ...) as a tensor on ``device``: the one conversion per env step.

    A numpy array bound for CUDA goes through page-locked (pinned) host memory and an asynchronous
    copy, so the transfer does not stage through pageable memory; torch's caching host allocator
    reuses the pinned blocks once their copy is done. On CPU the array is shared, not copied.
    """
    if isinstance(x, dict):  # Dict observations kept per key: each key converted, its dtype kept
        return ObsDict({k: to_device(v, device) for k, v in x.items()}, getattr(x, "batch_dims", 1))
    if device.type == "cuda" and isinstance(x, np.ndarray) and x.dtype != np.object_:
        x = np.ascontiguousarray(x) if x.flags.writeable else np.array(x)  # from_numpy wants writable
        host = torch.from_numpy(x)
        return host.pin_memory().to(device, non_blocking=True)
    return torch.as_tensor(x, device=device)


def describe(exc: BaseException) -> str:
    """``Type: message`` on one line."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
