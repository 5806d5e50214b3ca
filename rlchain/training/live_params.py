"""Live training parameters: the values population-based training (Ray Tune's PBT, a replayed
``hyperparam_schedule``) reads with :meth:`LiveParams.get_params` and changes with
:meth:`~LiveParams.set_params`.

The Loop holds one. ``set_params`` may come from another thread (a Tune trainable); the changes wait
in a locked queue and apply at the start of the next epoch (:meth:`~LiveParams.apply_pending`), each
one logged to TensorBoard as ``params/<name>``.
"""

from __future__ import annotations

import threading

from rlchain.algos.base.algorithm import Algorithm
from rlchain.algos.base.context import RunContext
from rlchain.log import get_logger

log = get_logger(__name__)


class LiveParams:
    """get/set of the algorithm's :attr:`~rlchain.algos.base.algorithm.Algorithm.tunable` parameters."""

    def __init__(self, ctx: RunContext, algorithm: Algorithm) -> None:
        self.ctx, self.algorithm = ctx, algorithm
        self._lock = threading.Lock()
        self._pending: dict[str, float] = {}

    def get_params(self) -> dict[str, float]:
        """The training parameters population-based training may change (see :meth:`set_params`)."""
        return self.algorithm.hyperparams()

    def set_params(self, **changes: float) -> None:
        """Change training parameters; they apply from the next epoch (thread-safe) and are logged."""
        check_tunable(changes, self.algorithm.tunable)
        with self._lock:
            self._pending.update(changes)

    def apply_pending(self) -> None:
        """Apply the changes :meth:`set_params` queued (start of an epoch), logging each one."""
        with self._lock:
            changes, self._pending = self._pending, {}
        for name, value in changes.items():
            self.algorithm.apply_hyperparam(name, value)
            self.ctx.logger.scalar(f"params/{name}", float(value), self.ctx.frames)
            if self.ctx.cfg.print_stats:  # quiet runs (tune trials, tests) keep it in TensorBoard only
                log.info(f"set {name} = {value} at epoch {self.ctx.epoch}")


def check_tunable(changes: dict[str, float], tunable: tuple[str, ...]) -> None:
    """KeyError naming the settable parameters when ``changes`` names another."""
    unknown = [k for k in changes if k not in tunable]
    if unknown:
        raise KeyError(f"cannot set {unknown[0]}; settable: {', '.join(tunable)}")
