"""Old public names kept importable for one release, with a DeprecationWarning naming the new one."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any


def renamed(module: str, names: dict[str, tuple[str, Any]]) -> Callable[[str], Any]:
    """A module ``__getattr__`` serving ``names`` (old name -> (new name, object)) with a warning.

    Used as ``__getattr__ = renamed(__name__, {"TrainConfig": ("PPOConfig", PPOConfig)})``: ``from
    module import TrainConfig`` still works and warns once per call site.
    """

    def __getattr__(name: str) -> Any:
        if name not in names:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        new, obj = names[name]
        warnings.warn(f"{module}.{name} is renamed {new}; the old name goes in the next release",
                      DeprecationWarning, stacklevel=2)
        return obj

    return __getattr__
