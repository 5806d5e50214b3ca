"""``params.config.hyperparam_schedule``: live hyperparameter values by epoch (a replayed PBT schedule)."""

from __future__ import annotations

from typing import Any


def check_hyperparam_schedule(value: Any) -> str | None:
    """An error string unless ``value`` is ``{epoch >= 0: {name: number}}``; names are checked
    against the algorithm's ``tunable`` when the Loop is built."""
    if not isinstance(value, dict):
        return f"expected a mapping epoch -> {{name: value}}, got {value!r}"
    for epoch, values in value.items():
        if isinstance(epoch, str) and epoch.isdigit():  # a key path override writes the epoch as a string
            epoch = int(epoch)
        if isinstance(epoch, bool) or not isinstance(epoch, int) or epoch < 0:
            return f"epoch {epoch!r}: expected an integer >= 0"
        if not isinstance(values, dict) or not values:
            return f"epoch {epoch}: expected a mapping name -> value, got {values!r}"
        for name, item in values.items():
            if isinstance(item, bool) or not isinstance(item, (int, float)):
                return f"{epoch}.{name}: expected a number, got {item!r}"
    return None
