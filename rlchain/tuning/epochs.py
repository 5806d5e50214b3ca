"""One epoch per call: a Runner's training, paced from outside (a Ray Tune trial's ``step``).

:class:`EpochStepper` runs ``Runner.train`` in a background thread with itself as a callback; at
each epoch's end the thread parks until the next :meth:`EpochStepper.next_epoch`. While it is
parked, between two epochs, the caller may save a checkpoint, load another one into the live run
(the envs keep running: population-based training's exploit), change the live hyperparameters
through the run's ``set_params`` (its explore step) and move the run's TensorBoard folder. The
Loop keeps every guarantee of a normal run (divergence guard, checkpoint on stop, closed envs).
"""

from __future__ import annotations

import queue
import threading
import time
from dataclasses import dataclass
from typing import Any

from rlchain.runs import checkpoint as ckpt
from rlchain.runs.logging import TrainLogger
from rlchain.runs.run_dir import create_run_dir
from rlchain.runs.writers import make_writers
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback


@dataclass
class EpochReport:
    """What one finished epoch reports."""

    epoch: int
    frames: int
    mean_reward: float | None  # None until an episode finished
    mean_length: float | None
    best_reward: float
    stats: dict[str, float]
    params: dict[str, float]  # the live tunable values (get_params)
    seconds: float  # wall time of this epoch, parking excluded


class EpochStepper(Callback):
    """Drives ``runner.train(checkpoint)`` one epoch at a time (see the module docstring)."""

    def __init__(self, runner: Any, checkpoint: str | None = None, live: dict[str, float] | None = None,
                 seed: int | None = None) -> None:
        self.runner = runner
        self.checkpoint = checkpoint  # resume from it when the thread starts
        self.live = dict(live or {})  # set_params at the start (over a checkpoint's restored values)
        self.seed = seed
        self.context: CallbackContext | None = None  # the run's, from its start on
        self._moved_logger: TrainLogger | None = None  # the logger of a moved run (this stepper closes it)
        self.result: Any = None  # the TrainResult once the run ended
        self.parked = False
        self._thread: threading.Thread | None = None
        self._events: queue.Queue = queue.Queue()
        self._commands: queue.Queue = queue.Queue()
        self._resumed_at = time.time()

    # ----- the caller's side ---------------------------------------------------------------
    @property
    def started(self) -> bool:
        return self._thread is not None

    def next_epoch(self) -> EpochReport | None:
        """Train one more epoch and return its report; None once the run has ended (its own stop
        rule came; ``self.result`` holds the TrainResult). An exception of the run is raised here."""
        if self.result is not None:
            return None
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="rlchain-train", daemon=True)
            self._resumed_at = time.time()
            self._thread.start()
        else:
            self._resume("go")
        return self._next_event()

    def _next_event(self) -> EpochReport | None:
        """Wait for the training thread's next event: its report (or None when it parked before a rollout);
        None and ``self.result`` set when the run ended; the run's exception raised here."""
        kind, item = self._events.get()
        if kind == "error":
            self._thread.join()
            raise item
        if kind == "end":
            self._thread.join()
            self.result = item
            return None
        return item

    def save(self, path: str) -> None:
        """Write the parked run's checkpoint (exact resume state) to ``path``."""
        if self.context is None or not (self.parked or self.result is not None):
            raise RuntimeError("the run can be saved only between epochs")
        ckpt.save_atomic(self.context.full_state(), path)

    def load(self, path: str) -> None:
        """Load a checkpoint into the parked run (weights, optimizer, counters); the envs keep
        running and start fresh episodes, so the next rewards are the loaded policy's."""
        context = self.context
        if context is None:
            self.checkpoint = path
            return
        if not self.parked:
            raise RuntimeError("a checkpoint can be loaded only between epochs")
        with ckpt.trusting(context.params.config.trust_checkpoint):
            state = ckpt.load(path)
        context.load_full_state(state, path)
        context.snapshot()  # the divergence guard rolls back to the loaded learner, not the old one

    def set_params(self, values: dict[str, float]) -> None:
        """Change live hyperparameters from the next epoch on (before the start: at the start)."""
        self.live.update(values)
        if self.context is not None:
            self.context.set_params(**values)

    def move_run(self, experiment: str) -> None:
        """Log and checkpoint the parked run under another run folder of the same train_dir, with the same
        checkpoint names (the run's layout) and the same console and TensorBoard tags (an actor Ray reuses for
        another trial keeps its envs but writes that trial's TensorBoard)."""
        context = self.context
        if context is None or context.run_dir is None:
            return
        cfg = context.params.config
        run = create_run_dir(cfg.train_dir, cfg.name, experiment, context.raw_config, layout=context.run_dir.layout)
        self._moved_logger = context.move_run(run, make_writers(cfg.log_writers, run.root))

    def shutdown(self, timeout: float = 60.0) -> None:
        """Stop the run after the parked epoch (it saves its last checkpoint) and wait for it."""
        if self._thread is None or not self._thread.is_alive():
            return
        if self.parked:
            self._resume("stop")
        self._thread.join(timeout)
        if self._moved_logger is not None:
            self._moved_logger.close()  # a moved run's logger (the Runner closes the one it made)

    # ----- the training thread's side --------------------------------------------------------
    def _resume(self, command: str) -> None:
        self.parked = False
        self._resumed_at = time.time()
        self._commands.put(command)

    def _run(self) -> None:
        try:
            result = self.runner.train(checkpoint=self.checkpoint, seed=self.seed, callbacks=[self])
        except BaseException as exc:  # handed to the caller's thread
            self._events.put(("error", exc))
            return
        self._events.put(("end", result))

    def on_train_start(self, ctx: CallbackContext) -> None:
        self.context = ctx
        self._resumed_at = time.time()  # the first epoch's time leaves out building the run
        if self.live:
            ctx.set_params(**self.live)

    def on_epoch_end(self, ctx: CallbackContext, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        state = ctx.state
        report = EpochReport(
            epoch=state.epoch, frames=state.frames,
            mean_reward=None if episodes is None else float(episodes["reward"]),
            mean_length=None if episodes is None else float(episodes.get("length", 0.0)),
            best_reward=state.best_reward, stats={k: float(v) for k, v in stats.items()},
            params={k: float(v) for k, v in ctx.get_params().items()
                    if isinstance(v, (int, float)) and not isinstance(v, bool)},
            seconds=time.time() - self._resumed_at)
        self.parked = True
        self._events.put(("epoch", report))
        if self._commands.get() == "stop":
            ctx.request_stop("ray tune")
