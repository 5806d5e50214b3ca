"""What keeps a run recoverable: stop signals, divergence checks and env failure reports."""

from __future__ import annotations

import copy
import signal
import threading
from typing import Any

import torch

from rlchain.errors import DivergenceError
from rlchain.log import get_logger

log = get_logger(__name__)


class UpdateInterrupted(Exception):
    """A stop signal came during an update: the algorithm left it between two minibatches; the loop puts
    back the learner of the last epoch boundary, so the checkpoint it saves resumes exactly."""


class StopSignals:
    """SIGINT / SIGTERM ask the loop to stop after the current env step or minibatch; a second one exits
    at once.

    Use as a context manager around training; ``requested`` holds the signal name once one came, or
    the reason a callback gave (:meth:`request`). Outside the main thread (where Python cannot
    install handlers) the signals do nothing.
    """

    def __init__(self) -> None:
        self.requested: str | None = None
        self.by_signal = False
        self._previous: dict[int, Any] = {}

    def request(self, reason: str) -> None:
        """A stop asked for in code (a callback, a tuner's pruner): kept unless a stop came already."""
        if self.requested is None:
            self.requested = reason

    def stop_reason(self) -> str:
        """'interrupted by SIGTERM' for a signal (the user's interruption, exit 130, resume line);
        'stopped by request: <reason>' for a stop asked for in code (a finished run)."""
        if self.by_signal:
            return f"interrupted by {self.requested}"
        return f"stopped by request: {self.requested}"

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: Any) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()

    def _handle(self, signum: int, frame: Any) -> None:
        name = signal.Signals(signum).name
        if self.by_signal:  # second signal: leave now
            raise KeyboardInterrupt(f"second {name}")
        self.requested = name
        self.by_signal = True
        # print, not logging: this runs in a signal handler, where logging's locks could deadlock
        print(f"\n{name} received: finishing the current env step or minibatch, then saving a checkpoint of "
              f"the last completed epoch (send it again to exit at once)", flush=True)


def check_parameters(module: torch.nn.Module) -> str | None:
    """The first parameter or buffer holding a NaN or inf, e.g. 'parameter network.mu.weight', else None."""
    for kind, items in (("parameter", module.named_parameters()), ("buffer", module.named_buffers())):
        for name, tensor in items:
            if tensor.is_floating_point() and not bool(torch.isfinite(tensor).all()):
                return f"{kind} {name}"
    return None


def check_rollout(rewards: torch.Tensor, obs: torch.Tensor, who: str = "") -> None:
    """A DivergenceError naming the first non-finite reward or observation of a rollout (T, N, ...), its env and
    step (after ``who``, e.g. ``policy red: ``)."""
    parts = [("reward", rewards)]
    parts += [(f"observation '{k}'", v) for k, v in obs.items()] if isinstance(obs, dict) else [("observation", obs)]
    for name, data in parts:
        if not data.is_floating_point():
            continue
        bad = ~torch.isfinite(data.reshape(data.shape[0], data.shape[1], -1)).all(-1)
        if bool(bad.any()):
            step, env = (int(i) for i in bad.nonzero()[0])
            raise DivergenceError(f"{who}the env returned a non-finite {name} (env {env}, step {step} of the rollout)")


class DivergenceGuard:
    """Keeps the last good learner state (when rollback is on) and decides what a NaN/inf means.

    ``cfg`` is the ``divergence`` block; ``model`` exposes state_dict/load_state_dict, ``agent`` keeps the
    :class:`~rlchain.algos.core.adam_agent.Agent` contract (state_dict/load_state_dict, ``lr``, ``scale_lr``).
    """

    def __init__(self, cfg: Any, model: Any, agent: Any) -> None:
        self.cfg, self.model, self.agent = cfg, model, agent
        self.rollbacks = 0
        self._good: dict[str, Any] | None = None
        self.good_epoch: int | None = None

    def snapshot(self, epoch: int | None = None) -> None:
        """Remember the current state (of ``epoch``, when given) as good: one in-memory copy, only with
        rollback on."""
        if self.cfg.action == "rollback":
            self._good = {"model": copy.deepcopy(self.model.state_dict()),
                          "agent": copy.deepcopy(self.agent.state_dict())}
            self.good_epoch = epoch

    def handle(self, exc: DivergenceError, epoch: int) -> None:
        """Roll back to the last good state and lower the lr, or raise a DivergenceError naming ``epoch``.

        ``epoch`` is the last completed one; the failed update belonged to epoch + 1. The good state
        is that epoch's unless :meth:`snapshot` named an earlier one (off-policy snapshots less often).
        """
        where = f"epoch {epoch + 1}: {exc}"
        good = epoch if self.good_epoch is None else self.good_epoch
        if self.cfg.action == "rollback" and self.rollbacks < self.cfg.max_rollbacks and self._good is not None:
            self.rollbacks += 1
            self._restore()
            self.agent.scale_lr(self.cfg.lr_factor ** self.rollbacks)
            log.warning(f"divergence at {where}; rolled back to epoch {good} ({self.rollbacks}/"
                        f"{self.cfg.max_rollbacks}), learning rate now {self.agent.lr:.2e}")
            return
        self._restore()
        kept = f"parameters of epoch {good} kept" if self._good is not None else "last good checkpoint kept"
        raise DivergenceError(f"training diverged at {where}; {kept} (checkpoints hold no NaN)") from None

    def _restore(self) -> None:
        if self._good is not None:
            self.model.load_state_dict(self._good["model"])
            self.agent.load_state_dict(self._good["agent"])
