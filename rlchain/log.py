"""rlchain's messages go through :mod:`logging`, under the ``rlchain`` logger and its children.

By default they are shown as plain lines on the current ``sys.stdout`` (as ``print`` would, so a
notebook, a captured test or a redirected run sees them). To route them elsewhere, or silence them,
configure the ``rlchain`` logger: ``logging.getLogger("rlchain").setLevel(logging.WARNING)``, or
replace its handlers. The console epoch line of a training run is output, not a log message.

While a training run shows its live status line on a terminal (rlchain/runs/progress.py), it is
registered with :func:`set_live_status`: a message erases it, is printed, and the line is redrawn under it.
"""

from __future__ import annotations

import logging
import sys
from typing import Any, TextIO

_live_status: Any = None  # the LiveStatus on the terminal, if any: hide() before a message, show() after


class _CurrentStdout(logging.StreamHandler):
    """A StreamHandler that always writes to the ``sys.stdout`` of the moment it emits."""

    def __init__(self) -> None:
        super().__init__()

    @property
    def stream(self) -> TextIO:  # type: ignore[override]
        return sys.stdout

    @stream.setter
    def stream(self, value: TextIO) -> None:  # StreamHandler.__init__ assigns it; the property wins
        pass

    def emit(self, record: logging.LogRecord) -> None:
        live = _live_status
        if live is None or live.stream is not sys.stdout:
            super().emit(record)
            return
        live.hide()  # the message on a clean line, the status line drawn again under it
        try:
            super().emit(record)
        finally:
            live.show()


def set_live_status(status: Any) -> None:
    """Register the live status line (an object with ``stream``, ``hide()`` and ``show()``) that rlchain's
    messages print above; None: there is none."""
    global _live_status
    _live_status = status


def _install() -> logging.Logger:
    root = logging.getLogger("rlchain")
    if not any(isinstance(h, _CurrentStdout) for h in root.handlers):
        handler = _CurrentStdout()
        handler.setFormatter(logging.Formatter("%(message)s"))
        root.addHandler(handler)
        root.setLevel(logging.INFO)
        root.propagate = False  # shown once, by this handler, not again by an application's root handler
    return root


_install()


def get_logger(name: str) -> logging.Logger:
    """The logger of module ``name`` (``rlchain.training.loop`` and so on)."""
    return logging.getLogger(name)


# ----- hints in the words the user launched with ----------------------------------------------------
DIALECTS = ("python", "rlchain", "runner.py")
_dialect = "python"  # the rlchain command and runner.py's flags set theirs for the duration of a call


def set_dialect(name: str) -> str:
    """How the user launched rlchain (one of :data:`DIALECTS`), for the commands hints print; returns the
    previous one, so a caller can put it back."""
    global _dialect
    if name not in DIALECTS:
        raise ValueError(f"dialect '{name}' is not one of {', '.join(DIALECTS)}")
    previous, _dialect = _dialect, name
    return previous


def train_hint(config: str | None, checkpoint: str | None = None) -> str:
    """The command that trains ``config`` (a path; None or ``<dict>``: a placeholder) from ``checkpoint``, in
    the dialect the user launched with: ``rlchain train cfg.yaml --checkpoint X``, ``python runner.py --train
    --file cfg.yaml --checkpoint X`` or ``Runner().load('cfg.yaml').train(checkpoint='X')``."""
    config = config if config and not config.startswith("<") else "<config>"
    if _dialect == "rlchain":
        return f"rlchain train {config}" + (f" --checkpoint {checkpoint}" if checkpoint else "")
    if _dialect == "runner.py":
        return f"python runner.py --train --file {config}" + (f" --checkpoint {checkpoint}" if checkpoint else "")
    return f"rlchain.Runner().load({config!r}).train(" + (f"checkpoint={checkpoint!r})" if checkpoint else ")")


def torchrun_hint(config: str | None) -> str:
    """The torchrun command that trains ``config`` on N processes, in the launch dialect."""
    config = config if config and not config.startswith("<") else "<config>"
    head = "torchrun --standalone --nproc_per_node=N"
    if _dialect == "rlchain":
        return f"{head} -m rlchain train {config} params.config.multi_gpu=True"
    return f"{head} runner.py --train --file {config} params.config.multi_gpu=True"
