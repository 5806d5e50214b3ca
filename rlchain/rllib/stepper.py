"""The training thread's pacing for RLlib's ``train()``: rlchain's :class:`EpochStepper`, which parks after every
epoch until the next ``train()``, also parked before the first rollout, so the model exists as soon as the
algorithm is built (as in RLlib). Stopped there, before any ``train()``, the run ends without parking again: an
off-policy epoch, which finishes before it takes a stop, is not held for a ``train()`` that never comes."""

from __future__ import annotations

import threading
import time

from rlchain.training.callback_context import CallbackContext
from rlchain.tuning.epochs import EpochStepper


class ParkingStepper(EpochStepper):
    """EpochStepper that also parks before the first rollout (the model exists then)."""

    _stopped_before_training = False

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="rlchain-rllib-train", daemon=True)
        self._thread.start()
        self._next_event()  # parked before the first rollout, or the run's end / exception

    def on_train_start(self, ctx: CallbackContext) -> None:
        super().on_train_start(ctx)
        self.parked = True
        self._events.put(("ready", None))
        if self._commands.get() == "stop":
            ctx.request_stop("algorithm stopped")
            self._stopped_before_training = True
        self._resumed_at = time.time()

    def on_epoch_end(self, ctx: CallbackContext, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        if not self._stopped_before_training:
            super().on_epoch_end(ctx, stats, episodes)
