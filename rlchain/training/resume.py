"""Exact resume: the run's state at the last epoch boundary, beyond the learner.

A checkpoint restores the learner (model, optimizer, normalizers, schedules, counters). For a resumed
run to be the run that never stopped, it also needs, as of the same epoch boundary: every random stream
(torch CPU and CUDA, numpy, Python ``random``; the minibatch shuffler and the replay sampler draw from
them), the envs' own state (physics, step counters, wrappers' filters, their generators: the optional
VecEnv ``get_state`` / ``set_state``), the episodes in progress and the algorithm's position in them
(its next observations, RNN states).

:class:`ResumePoint` captures that at every epoch boundary (:meth:`~ResumePoint.capture`, after the
update), so every checkpoint -- best, periodic, last, and the one a stop signal or an env error writes in
the middle of an epoch -- holds the state of one boundary: the learner does not change while an
on-policy epoch collects (off-policy epochs finish before a stop), so the learner and the boundary
agree. :meth:`~ResumePoint.restore` hands the saved state to the run context; the algorithm's
``start`` puts it back instead of resetting the envs. An env that cannot give its state resumes as
before (fresh episodes), and the resume says so in one line naming the env.
"""

from __future__ import annotations

import copy
from typing import Any, Protocol, runtime_checkable

from rlchain.algos.base.algorithm import Algorithm
from rlchain.algos.base.context import RunContext
from rlchain.envs.vecenv import StateUnavailable
from rlchain.log import get_logger
from rlchain.runs import checkpoint as ckpt

log = get_logger(__name__)


def env_label(ctx: RunContext) -> str:
    """The env as a user names it: ``env_name`` and the backend class (``CartPole-v1 (EnvpoolVecEnv)``)."""
    return f"{ctx.cfg.env_name} ({type(ctx.env).__name__})"


def check_run_state(state: dict[str, Any], path: str) -> None:
    """A checkpoint to resume from holds the state of its epoch boundary (``run_state``); one written by a
    pre-release rlchain does not, and is refused in one line before anything is loaded."""
    if "run_state" not in state:
        raise ckpt.CheckpointError(f"{path}: the checkpoint has no 'run_state' (written by a pre-release rlchain); "
                                   f"start a new run, or pass a checkpoint written by this rlchain")


@runtime_checkable
class ResumePosition(Protocol):
    """Optional part of an :class:`~rlchain.algos.base.algorithm.Algorithm`: where it stands in the envs'
    episodes between epochs, checkpointed with the envs' state for exact resume (its ``start`` puts it back
    through ``load_position``)."""

    def position_state(self) -> dict[str, Any] | None:
        """The observations it acts on next, RNN states, ... (copies); None before ``start``."""
        ...

    def load_position(self, position: dict[str, Any]) -> None:
        """Put back :meth:`position_state`."""
        ...

class ResumePoint:
    """The state of the last epoch boundary that checkpoints carry beyond the learner (module docstring)."""

    def __init__(self, ctx: RunContext, algorithm: Algorithm) -> None:
        self.ctx, self.algorithm = ctx, algorithm
        self.env_missing: str | None = None if ctx.spec.state else "the env has no get_state / set_state"
        self.boundary: dict[str, Any] | None = None
        self.rank_restored = False  # torchrun: this rank's own state came from the checkpoint

    def capture(self, gather: bool = True) -> None:
        """The state now, at an epoch boundary (after the update, or at the start of training). Under
        torchrun every rank's part is gathered (a collective: every rank calls this at the same point);
        ``gather=False`` (a rollback, which one rank may do alone) keeps this rank's part only."""
        ctx = self.ctx
        has_position = isinstance(self.algorithm, ResumePosition)  # AlgorithmBase has it; the core protocol not
        position = self.algorithm.position_state() if has_position else None
        env_state = self._env_state() if position is not None else None
        missing = (self.env_missing if position is not None else "training had not started" if has_position
                   else f"{type(self.algorithm).__name__} has no position_state")
        tracker = ctx.tracker
        own = {"rng": ckpt.rng_state(), "episodes": copy.deepcopy(tracker.state_dict()),
               "run_state": {"env": env_state, "env_missing": missing, "env_label": env_label(ctx),
                             "running": tracker.running_state(), "position": position}}
        self.boundary = {"epoch": ctx.epoch, "frames": ctx.frames, **own}
        if ctx.comm.active and gather:  # torchrun: every rank's part, for rank 0's checkpoints (every rank calls this)
            self.boundary["ranks"] = ctx.comm.gather_objects(own)

    def _env_state(self) -> Any:
        """The envs' state, or None (the env has none to give: said once, then not asked again)."""
        if self.env_missing is not None:
            return None
        try:
            return self.ctx.env.get_state()
        except StateUnavailable as exc:
            self.env_missing = str(exc)
            log.warning(f"warning: checkpoints will not hold the state of {env_label(self.ctx)}: {exc}; "
                        f"a resume restarts its episodes")
            return None

    def state(self) -> dict[str, Any]:
        """The checkpoint keys of the last boundary (captured now when there is none yet)."""
        if self.boundary is None or self.boundary["epoch"] != self.ctx.epoch:
            self.capture()
        return self.boundary

    def restore(self, state: dict[str, Any]) -> None:
        """After the learner and counters are restored: the RNG streams now, the envs' state and the
        episodes in progress at the algorithm's ``start``; one line when the envs restart their episodes."""
        ctx = self.ctx
        ranks = state.get("ranks")
        self.rank_restored = ctx.comm.active and ranks is not None and len(ranks) == ctx.world_size
        if self.rank_restored:  # torchrun: this rank's own streams, episodes and envs
            state = {**state, **ranks[ctx.comm.rank]}
            ctx.tracker.load_state_dict(state["episodes"])
        ckpt.set_rng_state(state["rng"])
        run_state = state["run_state"]
        # until the first epoch, a checkpoint of this run holds the restored boundary as it was saved
        self.boundary = {"epoch": ctx.epoch, "frames": ctx.frames, "rng": state["rng"],
                         "episodes": state["episodes"], "run_state": run_state}
        if ranks is not None and self.rank_restored:
            self.boundary["ranks"] = ranks
        if ctx.comm.active and not self.rank_restored:
            run_state = None  # rank 0's envs are not this rank's: every rank starts new episodes
            why_ranks = (f"the checkpoint holds {len(ranks)} ranks' state, this run has {ctx.world_size}"
                         if ranks is not None else "the checkpoint holds one process's state")
            log.warning(f"resume: {env_label(ctx)} on rank {ctx.comm.rank} starts new episodes: {why_ranks}; "
                        f"the learner and counters are restored, this rank's random streams are reseeded")
            return
        why = None
        if run_state["env"] is None:
            why = f"the checkpoint holds no env state ({run_state.get('env_missing')})"
        elif not ctx.spec.state:
            why = f"this env cannot take a saved state (no get_state / set_state; saved from {run_state['env_label']})"
        if why is not None:
            log.warning(f"resume: {env_label(ctx)} starts new episodes: {why}; the learner, counters, "
                        f"random streams and finished-episode statistics are restored")
            return
        ctx.resume_state = run_state

    def _no_run_state(self) -> dict[str, Any]:
        """The run_state of a checkpoint that keeps none (an rl_games one): no env state, nothing running."""
        return {"env": None, "env_missing": "the checkpoint keeps none", "env_label": env_label(self.ctx),
                "running": self.ctx.tracker.running_state(), "position": None}

    def after_start(self) -> None:
        """After the algorithm's ``start``: an algorithm that did not take the saved env state (it resets
        its envs itself, e.g. APPO's runners) is said in one line."""
        ctx = self.ctx
        if ctx.resume_state is not None:
            ctx.resume_state = None
            log.warning(f"resume: {env_label(ctx)} starts new episodes: {type(self.algorithm).__name__} does "
                        f"not restore the env state; the learner, counters and random streams are restored")
