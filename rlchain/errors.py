"""Run-time errors shared across layers (config errors live in rlchain.config.errors), and the one
did-you-mean that every "unknown name" message carries (config keys, registries, env options)."""

import difflib
import sys
from collections.abc import Iterable
from types import ModuleType


class DivergenceError(RuntimeError):
    """A NaN or inf in a loss, the gradients, the parameters or the env's data."""


class EnvError(RuntimeError):
    """The environment raised, or returned data that does not fit its declared space."""


class NetworkError(RuntimeError):
    """A network broke its contract at run time, e.g. ``get_aux_loss()`` returned a non-scalar loss."""


class CallbackError(RuntimeError):
    """A user's callback raised while the envs stepped; ``__cause__`` is the callback's own exception, which
    the loop re-raises as it was (after saving the last completed epoch)."""

    def __init__(self, callback: str, event: str, cause: BaseException) -> None:
        super().__init__(f"callback {callback} failed in {event}: {type(cause).__name__}: {cause}")
        self.callback, self.event = callback, event


class DistributedError(RuntimeError):
    """Under torchrun, a collective failed: another rank died, was killed or hung (multi_gpu)."""


def optional_import(name: str, hint: str) -> ModuleType:
    """The optional dependency ``name`` (a literal of rlchain's own: ``optuna``, ``ray.tune``, ``wandb`` ...), or
    an ImportError whose one line is ``hint`` (what to install)."""
    try:
        __import__(name)
    except ImportError:
        raise ImportError(hint) from None
    return sys.modules[name]


def first_non_finite(named: dict[str, float]) -> str | None:
    """The first ``name = value`` whose value is NaN or inf, else None."""
    for name, value in named.items():
        if value != value or value in (float("inf"), float("-inf")):
            return f"{name} = {value}"
    return None


def closest(name: object, candidates: Iterable[object], n: int = 3) -> list[str]:
    """Up to ``n`` of ``candidates`` closest to ``name`` (case-insensitive, best first), as written."""
    by_lower = {str(c).lower(): str(c) for c in candidates}
    return [by_lower[c] for c in difflib.get_close_matches(str(name).lower(), list(by_lower), n=n, cutoff=0.6)]


def did_you_mean(name: object, candidates: Iterable[object], n: int = 3) -> str:
    """"; did you mean 'X', 'Y'?" for the closest candidates (:func:`closest`), or ''."""
    close = closest(name, candidates, n)
    return f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
