"""The user's callbacks as the algorithm calls them: ``callbacks(MyCallback)`` (a class, an instance or a list of
them) and ``callbacks(on_train_result=fn, ...)`` (single functions by event name)."""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.rllib.callbacks.callbacks import RLlibCallback


def callback_objects(value: Any) -> list[RLlibCallback]:
    """The callbacks of ``config.callbacks_class``: each class instantiated; a one-line error for anything else."""
    items = value if isinstance(value, (list, tuple)) else ([] if value is None else [value])
    out = []
    for item in items:
        obj = item() if isinstance(item, type) else item
        if not isinstance(obj, RLlibCallback) and not all(callable(getattr(obj, n, None)) for n in
                                                          ("on_train_result", "on_episode_end")):
            raise ConfigError("AlgorithmConfig.callbacks()", "callbacks_class", f"{item!r}: expected an "
                              f"RLlibCallback subclass")
        out.append(obj)
    return out


class EventFunctions(RLlibCallback):
    """``callbacks(on_train_result=fn, ...)``: single functions by event name."""

    def __init__(self, functions: dict[str, Any]) -> None:
        for name, fn in functions.items():
            fns = fn if isinstance(fn, (list, tuple)) else [fn]
            setattr(self, name, lambda *a, _fns=fns, **k: [f(*a, **k) for f in _fns])
