"""Log destinations behind one small interface: a :class:`Writer` gets every scalar of a run.

The trainer's :class:`~rlchain.runs.logging.TrainLogger` hands each batch of scalars, keyed by
rl_games' TensorBoard tags (``rewards/step``, ``losses/a_loss``, ``performance/step_fps`` ...), to
every writer with the run's counters (:class:`Step`: frames, epoch, seconds). rl_games writes one
value against several x-axes (``rewards/step`` at frames, ``rewards/iter`` at epochs,
``rewards/time`` at whole seconds): :meth:`Step.x` gives the x value of a tag by that rule, so a
writer can keep the three counters or use the one the tag implies.

Built in: :class:`ConsoleWriter` (the progress line, ``print_stats``), :class:`TensorBoardWriter`
(the run's ``summaries/``), :class:`WandbWriter` (``--track``) and :class:`CSVWriter`. Extra
writers are named in ``params.config.log_writers``; a user's own registers like the other
extension points::

    from rlchain.runs.writers import Writer, register_writer

    class PrintWriter(Writer):
        def __init__(self, run_dir):        # the run folder (runs/<name>_<date-time>)
            ...
        def write(self, scalars, step):      # {tag: value}, Step(frames, epoch, seconds)
            ...

    register_writer("print", PrintWriter)   # params.config.log_writers: [print]
"""

from __future__ import annotations

import collections
import csv
import math
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.run import ProgressConfig
from rlchain.errors import did_you_mean
from rlchain.log import get_logger, set_live_status
from rlchain.registry import WRITERS
from rlchain.runs.atomic import open_append
from rlchain.runs.progress import (
    DEFAULT_LIVE_SECONDS,
    LiveStatus,
    StatusFields,
    live_wanted,
    run_eta,
    score_eta,
    status_line,
)
from rlchain.runs.wandb_logger import start_wandb

log = get_logger(__name__)
KEY = "params.config.log_writers"
SCORE_WINDOW = 10  # epochs of mean reward the ETA by score_to_win reads the trend from


@dataclass(frozen=True)
class Step:
    """The run's counters when scalars are written: env ``frames``, ``epoch`` and ``seconds`` since
    the start; ``at``: the x value a caller gave explicitly (``add_scalar(tag, value, step)``)."""

    frames: int
    epoch: int
    seconds: float
    at: float | None = None

    def x(self, tag: str) -> float:
        """The x value rl_games writes ``tag`` against: ``at`` when given, else epochs for ``*/iter``,
        whole seconds for ``*/time`` and frames for every other tag."""
        if self.at is not None:
            return self.at
        if tag.endswith("/iter"):
            return self.epoch
        if tag.endswith("/time"):
            return int(self.seconds)
        return self.frames


@dataclass(frozen=True)
class EpochSummary:
    """What the progress line of one epoch shows (``None``: no game finished yet)."""

    epoch: int
    max_epochs: int
    frames: int
    seconds: float
    fps: float
    step_fps: float
    reward: float | None
    length: float | None
    success: float | None
    best: float
    fields: Sequence[str] = ()  # the algorithm's own ``name value`` fields
    max_frames: int = 0  # the run's frame limit (<= 0: none), for the live status's ETA
    score_to_win: float = math.inf  # the run's score stop (inf: none), for the ETA by the reward's trend


class Writer:
    """A log destination. ``write`` is the one required method; the others default to nothing."""

    def write(self, scalars: Mapping[str, float], step: Step) -> None:
        """Record ``scalars`` (``{tag: value}``) at ``step``."""
        raise NotImplementedError

    def epoch_end(self, summary: EpochSummary) -> None:
        """One epoch is logged (its scalars were written just before): a human-readable summary."""

    def flush(self) -> None:
        """Push what is buffered to its destination."""

    def close(self) -> None:
        """The run ended; release files and connections."""


def epoch_line(s: EpochSummary) -> str:
    """The plain epoch line: ``epoch 3/100 | frames 1536 | fps ... | reward ... | best ... | len ... | 12s``."""
    limit = f"/{s.max_epochs}" if s.max_epochs > 0 else ""
    reward = f"{s.reward:.2f}" if s.reward is not None else "-"
    length = f"{s.length:.1f}" if s.length is not None else "-"
    best = f"{s.best:.2f}" if math.isfinite(s.best) else "-"
    fields = [f"success {s.success:.2f}", *s.fields] if s.success is not None else list(s.fields)
    extra = "".join(f" | {field}" for field in fields)
    return (f"epoch {s.epoch}{limit} | frames {s.frames} | fps {s.fps:.0f} (step {s.step_fps:.0f}) | "
            f"reward {reward} | best {best} | len {length}{extra} | {int(s.seconds)}s")


class ConsoleWriter(Writer):
    """The progress line (``print_stats``): ``epoch 3/100 | frames 1536 | fps ... | reward ... | best ...``.

    Off a terminal, one plain line per epoch (or every ``progress.print_every_epochs`` / ``_seconds``).
    On a terminal (``progress.live``, rlchain/runs/progress.py) also a live status line with the
    limit, ETA, fps, reward and success rate, redrawn in place under the epoch lines, which then
    come every 10 s unless ``progress`` says otherwise. The first epoch's line, the line of the epoch
    that reaches ``max_epochs`` / ``max_frames`` and, when the run ends, the last one are always printed."""

    def __init__(self, stream: Any = None, progress: ProgressConfig | None = None) -> None:
        self.stream = stream or sys.stdout
        progress = progress or ProgressConfig()
        self.live = LiveStatus(self.stream) if live_wanted(progress.live, self.stream) else None
        every_epochs, every_seconds = progress.print_every_epochs, progress.print_every_seconds
        if every_epochs is None and every_seconds is None:
            every_epochs, every_seconds = (None, DEFAULT_LIVE_SECONDS) if self.live else (1, None)
        self.every_epochs, self.every_seconds = every_epochs, every_seconds
        self.first: EpochSummary | None = None  # this process's first epoch: the ETA's reference
        self.printed_at = 0.0  # seconds of the last printed line
        self.pending: str | None = None  # the last epoch line, when it was not printed
        self.rewards: collections.deque = collections.deque(maxlen=SCORE_WINDOW)  # (seconds, reward): its trend

    def write(self, scalars: Mapping[str, float], step: Step) -> None:
        pass  # the line is written once per epoch, from the summary

    def _due(self, s: EpochSummary) -> bool:
        """Whether this epoch's line is printed."""
        if self.first is s or (s.max_epochs > 0 and s.epoch >= s.max_epochs) or \
                (s.max_frames > 0 and s.frames >= s.max_frames):
            return True
        if self.every_epochs is not None and s.epoch % self.every_epochs == 0:
            return True
        return self.every_seconds is not None and s.seconds - self.printed_at >= self.every_seconds

    def epoch_end(self, s: EpochSummary) -> None:
        if self.first is None:
            self.first = s
        line = epoch_line(s)
        if self._due(s):
            self.printed_at, self.pending = s.seconds, None
            if self.live is not None:
                self.live.print(line, redraw=False)  # the new status follows
            else:
                print(line, file=self.stream, flush=True)
        else:
            self.pending = line
        if self.live is not None:
            first = self.first
            if s.reward is not None:
                self.rewards.append((s.seconds, s.reward))
            eta = None if first is s else run_eta(s.epoch, s.max_epochs, s.frames, s.max_frames, first.epoch,
                                                  first.frames, s.seconds - first.seconds,
                                                  score_eta(self.rewards, s.score_to_win))
            self.live.show(status_line(StatusFields(s.epoch, s.max_epochs, s.frames, s.max_frames, s.fps, s.reward,
                                                    s.success, s.seconds, eta)))
            set_live_status(self.live)  # rlchain's log messages print above the status line

    def flush(self) -> None:
        """The run is ending (or pausing): the last epoch line, if it was skipped, and no status line."""
        if self.live is not None:
            self.live.hide()
            set_live_status(None)  # drawn again at the next epoch
        if self.pending is not None:
            print(self.pending, file=self.stream, flush=True)
            self.pending = None

    def close(self) -> None:
        self.flush()
        self.live = None


class TensorBoardWriter(Writer):
    """rl_games' TensorBoard event files in ``summaries_dir``, each tag at its :meth:`Step.x`."""

    def __init__(self, summaries_dir: str) -> None:
        from torch.utils.tensorboard import SummaryWriter

        self.summary_writer: Any = SummaryWriter(summaries_dir, flush_secs=10)

    def write(self, scalars: Mapping[str, float], step: Step) -> None:
        for tag, value in scalars.items():
            self.call("add_scalar", tag, value, step.x(tag))

    def call(self, method: str, *args: Any, **kwargs: Any) -> None:
        """Any SummaryWriter method (a callback's ``add_histogram`` ...); a failed write disables the
        writer with one warning, training goes on."""
        if self.summary_writer is None:
            return
        try:
            getattr(self.summary_writer, method)(*args, **kwargs)
        except OSError as exc:
            log.warning(f"warning: TensorBoard log write failed ({exc.strerror or exc}); training goes on without "
                        f"logs, checkpoints are unaffected")
            self.summary_writer = None

    def flush(self) -> None:
        self.call("flush")

    def close(self) -> None:
        self.call("close")


class WandbWriter(Writer):
    """Weights & Biases (``--track``): ``wandb.log`` of the tagged scalars, ``global_step`` = frames.

    ``start_wandb`` (rlchain.runs.wandb_logger) starts the run (project, entity, config, folder,
    offline mode, one-line errors); ``exit_code`` is what ``close`` finishes it with."""

    def __init__(self, project: str, entity: str | None, config: dict, run_name: str, summaries_dir: str) -> None:
        self.run = start_wandb(project, entity, config, run_name, summaries_dir)
        self.exit_code: int | None = None

    def write(self, scalars: Mapping[str, float], step: Step) -> None:
        self.run.wandb_run.log({**scalars, "global_step": step.frames})

    def close(self) -> None:
        self.run.finish(exit_code=self.exit_code)


class CSVWriter(Writer):
    """``<run_dir>/summaries/scalars.csv``: one row per scalar, ``frames,epoch,seconds,tag,value``
    (long format: tags may come and go between epochs). Also the example of a user's own writer."""

    FILE = "scalars.csv"

    def __init__(self, run_dir: str) -> None:
        folder = os.path.join(run_dir, "summaries")
        os.makedirs(folder, exist_ok=True)
        self.path = os.path.join(folder, self.FILE)
        self._file = open_append(self.path)  # a resumed run with the same folder appends
        self._csv = csv.writer(self._file)
        if self._file.tell() == 0:
            self._csv.writerow(["frames", "epoch", "seconds", "tag", "value"])

    def write(self, scalars: Mapping[str, float], step: Step) -> None:
        for tag, value in scalars.items():
            self._csv.writerow([step.frames, step.epoch, round(step.seconds, 3), tag, value])

    def flush(self) -> None:
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def register_writer(name: str, cls: Any, overwrite: bool = False) -> None:
    """Make ``cls`` (called as ``cls(run_dir)``, returning a :class:`Writer`) available to
    ``params.config.log_writers`` as ``name``."""
    WRITERS.register(name, cls, overwrite=overwrite)


def check_writer_names(names: Sequence[str], source: str = "") -> None:
    """ConfigError (one line: file, key, registered names, did-you-mean) for a name nobody registered."""
    for i, name in enumerate(names):
        if name not in WRITERS:
            hint = did_you_mean(name, WRITERS.names())
            raise ConfigError(source, f"{KEY}[{i}]", f"unknown log writer '{name}'{hint} "
                                                    f"(registered: {', '.join(WRITERS.names())})")


def make_writers(names: Sequence[str], run_dir: str, source: str = "") -> list[Writer]:
    """The writers ``params.config.log_writers`` names, each made for the run folder ``run_dir``."""
    check_writer_names(names, source)
    return [WRITERS.get(name)(run_dir) for name in names]


__all__ = ["Step", "EpochSummary", "epoch_line", "Writer", "ConsoleWriter", "TensorBoardWriter", "WandbWriter",
           "CSVWriter",            "register_writer", "check_writer_names", "make_writers"]
