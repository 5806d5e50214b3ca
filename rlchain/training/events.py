"""Training events: callbacks a user registers from Python or names in the config.

    class MyCallback(rlchain.training.events.Callback):
        def on_epoch_end(self, trainer, stats, episodes): ...

    Runner().load(cfg).train(callbacks=[MyCallback()])       # or in YAML:
    config: {callbacks: ["mypkg.callbacks:MyCallback"]}

A plain function ``fn(trainer, stats, episodes)`` is an ``on_epoch_end`` callback. An rl_games
``AlgoObserver`` (before_init / after_init / after_print_stats / after_clear_stats) is adapted.
Built-in in-training evaluation is one of these callbacks.
"""

from __future__ import annotations

import importlib
import time
from typing import Any

EVENTS = ("on_train_start", "on_epoch_end", "on_evaluation", "on_checkpoint", "on_train_end")


class Callback:
    """Override the events you need; every method is a no-op by default."""

    def on_train_start(self, trainer: Any) -> None:
        """Before the first rollout (after a resume restored its state)."""

    def on_epoch_end(self, trainer: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        """After an epoch's update and logging: ``stats`` are losses/kl/lr, ``episodes`` mean reward/length."""

    def on_evaluation(self, trainer: Any, result: Any) -> None:
        """After an in-training evaluation; ``result`` is a PlayResult."""

    def on_checkpoint(self, trainer: Any, path: str, kind: str) -> None:
        """After a checkpoint was written (``kind``: best, last, ep_N)."""

    def on_train_end(self, trainer: Any, result: Any) -> None:
        """After training stopped; ``result`` is the TrainResult."""


class FunctionCallback(Callback):
    """A plain function used as ``on_epoch_end``."""

    def __init__(self, fn: Any) -> None:
        self.fn = fn

    def on_epoch_end(self, trainer: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        self.fn(trainer, stats, episodes)


class AlgoObserverCallback(Callback):
    """Drives an rl_games AlgoObserver from rlchain's events."""

    def __init__(self, observer: Any) -> None:
        self.observer = observer
        self.start = time.time()

    def _call(self, name: str, *args: Any) -> None:
        method = getattr(self.observer, name, None)
        if method is not None:
            method(*args)

    def on_train_start(self, trainer: Any) -> None:
        self.start = time.time()
        self._call("before_init", trainer.cfg.name, trainer.raw_config, trainer.run.root if trainer.run else "")
        self._call("after_init", trainer)

    def on_epoch_end(self, trainer: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        self._call("after_steps")
        self._call("after_print_stats", trainer.frames, trainer.epoch, time.time() - self.start)


def as_callback(obj: Any) -> Callback:
    """Wrap whatever the user gave: a Callback, an AlgoObserver-like object or a function."""
    if isinstance(obj, Callback):
        return obj
    if any(hasattr(obj, name) for name in ("after_print_stats", "after_init", "before_init")):
        return AlgoObserverCallback(obj)
    if callable(obj):
        return FunctionCallback(obj)
    raise TypeError(f"{obj!r} is not a callback: subclass rlchain.training.events.Callback")


def load_callback(spec: str) -> Callback:
    """``module:Name`` from the config: a class is instantiated without arguments."""
    module_name, _, attr = spec.partition(":")
    if not attr:
        raise ValueError(f"callback '{spec}' must look like 'package.module:Name'")
    obj = getattr(importlib.import_module(module_name), attr)
    return as_callback(obj() if isinstance(obj, type) else obj)


class CallbackList:
    """Dispatches each event to every callback in order."""

    def __init__(self, callbacks: list[Any] | None = None) -> None:
        self.callbacks = [as_callback(c) for c in callbacks or []]

    def add(self, callback: Any) -> None:
        self.callbacks.append(as_callback(callback))

    def extend(self, callbacks: list[Any]) -> None:
        for callback in callbacks:
            self.add(callback)

    def __iter__(self):
        return iter(self.callbacks)

    def emit(self, event: str, *args: Any) -> None:
        for callback in self.callbacks:
            getattr(callback, event)(*args)
