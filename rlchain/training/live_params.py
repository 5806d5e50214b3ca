"""Live training parameters: the values population-based training (Ray Tune's PBT, a replayed
``hyperparam_schedule``) reads with :meth:`LiveParamsMixin.get_params` and changes with
:meth:`~LiveParamsMixin.set_params`.

A mixin of :class:`rlchain.training.loop.Loop`. ``set_params`` may come from another thread (a Tune
trainable); the changes wait in a locked queue and apply at the start of the next epoch
(:meth:`~LiveParamsMixin._apply_pending_params`), each one logged to TensorBoard as ``params/<name>``.
"""

from __future__ import annotations

import dataclasses
import threading
from typing import Any, ClassVar

from rlchain.log import get_logger

log = get_logger(__name__)


class LiveParamsMixin:
    """get/set of the :attr:`tunable` parameters for the Loop (which provides cfg, logger, frames, epoch)."""

    tunable: ClassVar[tuple[str, ...]] = ()
    cfg: Any
    logger: Any
    frames: int
    epoch: int

    def _init_live_params(self) -> None:
        """The empty queue of pending changes and its lock (called by the Loop's constructor)."""
        self._params_lock = threading.Lock()
        self._pending_params: dict[str, float] = {}
        self.live_config: dict[str, Any] = {}  # tunable config fields changed during the run (set_params)

    def hyperparams(self) -> dict[str, float]:
        """The live values of :attr:`tunable` (default: the config's)."""
        return {name: getattr(self.cfg, name) for name in self.tunable}

    def apply_hyperparam(self, name: str, value: float) -> None:
        """Change one tunable value (default: a config field, keeping its type). The parsed config is
        frozen: the run goes on with a copy holding the new value (:attr:`live_config`, checkpointed)."""
        current = getattr(self.cfg, name)
        value = type(current)(value) if current is not None else value
        self.live_config[name] = value
        old, self.cfg = self.cfg, dataclasses.replace(self.cfg, **{name: value})
        for part in list(vars(self).values()):  # the agents (and guards) that read the run's config
            own = getattr(part, "__dict__", None)  # their own attribute only: no proxy's __getattr__ runs
            if part is not self and isinstance(own, dict) and own.get("cfg") is old:
                part.cfg = self.cfg

    def get_params(self) -> dict[str, float]:
        """The training parameters population-based training may change (see :meth:`set_params`)."""
        return self.hyperparams()

    def set_params(self, **changes: float) -> None:
        """Change training parameters; they apply from the next epoch (thread-safe) and are logged."""
        unknown = [k for k in changes if k not in self.tunable]
        if unknown:
            raise KeyError(f"cannot set {unknown[0]}; settable: {', '.join(self.tunable)}")
        with self._params_lock:
            self._pending_params.update(changes)

    def _apply_pending_params(self) -> None:
        """Apply the changes :meth:`set_params` queued (start of an epoch), logging each one."""
        with self._params_lock:
            changes, self._pending_params = self._pending_params, {}
        for name, value in changes.items():
            self.apply_hyperparam(name, value)
            self.logger.scalar(f"params/{name}", float(value), self.frames)
            if self.cfg.print_stats:  # quiet runs (tune trials, tests) keep it in TensorBoard only
                log.info(f"set {name} = {value} at epoch {self.epoch}")
