"""The Loop's checkpoints: what a checkpoint holds (:meth:`CheckpointMixin.state_dict`), writing it
(:meth:`~CheckpointMixin.save`) and resuming from it (:meth:`~CheckpointMixin.restore`).

A mixin of :class:`rlchain.training.loop.Loop`: it reads the Loop's counters, model, agent, episode
tracker, run directory and events; the file format itself lives in :mod:`rlchain.runs.checkpoint`.
"""

from __future__ import annotations

from typing import Any

from rlchain.config.resolve import CONFIG_FORMAT, config_state
from rlchain.log import get_logger
from rlchain.runs import checkpoint as ckpt
from rlchain.training.safety import check_parameters
from rlchain.version import __version__

log = get_logger(__name__)


class CheckpointMixin:
    """Checkpoint save/restore for the Loop (which provides every attribute used here)."""

    params: Any
    model: Any
    agent: Any
    epoch: int
    frames: int
    best_reward: float
    tracker: Any
    seed: int
    run: Any
    events: Any
    device: Any
    comm: Any
    world_size: int
    cfg: Any
    live_config: dict
    tunable: Any

    def extra_state(self, kind: str) -> dict[str, Any]:
        """What a subclass adds to a checkpoint of ``kind`` (best, last, ep_N)."""
        return {}

    def restore_extra(self, state: dict[str, Any]) -> None:
        """Restore what :meth:`extra_state` added."""

    def state_dict(self, kind: str = "last") -> dict[str, Any]:
        """Everything exact resume needs."""
        state = {
            "format": ckpt.FORMAT, "algo": self.params.algo.name, "model_name": self.params.model.name,
            "config": config_state(self.params, {"seed": self.seed, "device": str(self.device),  # the run context
                                                 "rank": int(getattr(self.comm, "rank", 0)),
                                                 "world_size": self.world_size, "print_stats": self.cfg.print_stats}),
            "config_format": CONFIG_FORMAT, "live_config": dict(self.live_config),
            "model": self.model.state_dict(), "agent": self.agent.state_dict(),
            "epoch": self.epoch, "frames": self.frames, "best_reward": self.best_reward,
            "episodes": self.tracker.state_dict(), "rng": ckpt.rng_state(), "seed": self.seed,
            "version": _version(),
        }
        state.update(self.extra_state(kind))
        return state

    def save(self, kind: str) -> str | None:
        """Write a checkpoint; a failed write is reported and training keeps the previous one."""
        if self.run is None:
            return None
        bad = check_parameters(self.model)
        if bad is not None:
            log.warning(f"warning: not saving the {kind} checkpoint: {bad} is not finite")
            return None
        path = self.run.checkpoint(kind)
        try:
            ckpt.save_atomic(self.state_dict(kind), path)
        except OSError as exc:
            log.warning(f"warning: checkpoint write to {path} failed ({exc.strerror or exc}); the previous "
                        f"checkpoint is kept and training goes on")
            return None
        self.events.emit("on_checkpoint", path, kind)
        return path

    def restore(self, state: dict[str, Any], path: str) -> None:
        """Continue from a checkpoint: weights, optimizer(s), lr, normalizers, counters, RNG."""
        if state.get("algo") not in (None, self.params.algo.name):
            raise ckpt.CheckpointError(f"{path}: checkpoint was trained with algo '{state['algo']}', "
                                       f"the config says '{self.params.algo.name}'")
        ckpt.load_model_state(self.model, state, path)
        self.agent.load_state_dict(state["agent"])
        self.epoch, self.frames = int(state["epoch"]), int(state["frames"])
        for name, value in state.get("live_config", {}).items():  # values set_params gave the config fields
            if name in self.tunable:
                self.apply_hyperparam(name, value)
        self.best_reward = float(state["best_reward"])
        self.tracker.load_state_dict(state["episodes"])
        ckpt.set_rng_state(state["rng"])
        self.restore_extra(state)


def _version() -> str:
    return __version__
