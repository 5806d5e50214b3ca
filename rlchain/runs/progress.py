"""The live status line of a training run on a terminal, and the pure functions that format it.

On a terminal, :class:`~rlchain.runs.writers.ConsoleWriter` keeps one status line at the bottom::

    [#####.......] epoch 12/100 | frames 24.6k/200k | 1.2k fps | reward 123.4 | success 0.45 | 0:42 | ETA 5:10

redrawn in place (carriage return + ANSI erase-line) after every epoch, with the full epoch lines
printed above it every N epochs or seconds (``config.progress``). It is written here, without rich
or tqdm: neither is an install requirement of rlchain (rich comes only with the brax / playground
extras, tqdm with tune / video), a status line needs two control sequences every terminal since
VT100 (and Windows 10's console) understands, and rlchain's log messages must clear and redraw it
(:func:`rlchain.log.set_live_status`), which a library's own redirection would fight with.

Off a terminal (a pipe, a file, CI, nohup, a notebook) nothing here is used: plain epoch lines, as
always. ``RLCHAIN_PROGRESS=0`` (or ``off``) turns the live line off, ``1`` (``on``) forces it.
"""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

ENV_VAR = "RLCHAIN_PROGRESS"
ERASE_LINE = "\r\x1b[K"  # back to column 0, erase to the end of the line
DEFAULT_LIVE_SECONDS = 10.0  # epoch lines under the live view, when config.progress names no interval


def format_duration(seconds: float | None) -> str:
    """``42s``, ``5:07`` (minutes:seconds) or ``1:02:03`` (hours); ``?`` for an unknown or infinite time."""
    if seconds is None or not math.isfinite(seconds) or seconds < 0:
        return "?"
    total = int(seconds)  # whole seconds elapsed, as the epoch line counts them
    if total < 60:
        return f"{total}s"
    hours, rest = divmod(total, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"


def format_count(value: float) -> str:
    """A count or rate in three significant figures with a k / M / G suffix: ``950``, ``24.6k``, ``1.20M``."""
    value = float(value)
    if not math.isfinite(value):
        return "?"
    for suffix, scale in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if abs(value) >= scale * 0.9995:  # 999_600 is 1.00M, not 1000k
            scaled = value / scale
            return f"{scaled:.3g}{suffix}" if abs(scaled) < 100 else f"{scaled:.0f}{suffix}"
    return f"{value:.0f}"


def format_value(value: float) -> str:
    """A reward as the status line shows it: four significant digits, whole numbers from 1000 up (no exponent)."""
    return f"{value:.0f}" if abs(value) >= 1000 else f"{value:.4g}"


def eta_seconds(done: float, limit: float, done_at_start: float, elapsed: float) -> float | None:
    """Seconds left to reach ``limit`` at the average rate of this process: ``(limit - done) * elapsed /
    (done - done_at_start)``. ``done_at_start``: the count when this process started (a resumed run's
    epochs before it do not count towards its rate). None: no limit (``limit <= 0``) or no progress yet."""
    if limit <= 0:
        return None
    if done >= limit:
        return 0.0
    progressed = done - done_at_start
    if progressed <= 0 or elapsed <= 0:
        return None
    return (limit - done) * elapsed / progressed


def score_eta(history: Sequence[tuple[float, float]], score: float) -> float | None:
    """Seconds until the mean reward reaches ``score`` (``score_to_win``) at its recent rate: the slope from the
    oldest to the newest ``(seconds, reward)`` of ``history``. None: no finite score, fewer than two points, or
    a reward that is not rising (then no stop by score can be estimated)."""
    if not math.isfinite(score) or len(history) < 2:
        return None
    (t0, r0), (t1, r1) = history[0], history[-1]
    if r1 >= score:
        return 0.0
    if t1 <= t0 or r1 <= r0:
        return None
    return (score - r1) * (t1 - t0) / (r1 - r0)


def run_eta(epoch: int, max_epochs: int, frames: int, max_frames: int, start_epoch: int, start_frames: int,
            elapsed: float, by_score: float | None = None) -> float | None:
    """The run's ETA: the soonest of the epoch limit, the frame limit and ``by_score`` (:func:`score_eta`),
    whichever would stop the run first."""
    etas = [eta for eta in (eta_seconds(epoch, max_epochs, start_epoch, elapsed),
                            eta_seconds(frames, max_frames, start_frames, elapsed), by_score) if eta is not None]
    return min(etas) if etas else None


def fraction_done(epoch: int, max_epochs: int, frames: int, max_frames: int) -> float | None:
    """How far the run is towards the limit that stops it first, 0..1; None without a limit."""
    parts = [min(1.0, done / limit) for done, limit in ((epoch, max_epochs), (frames, max_frames)) if limit > 0]
    return max(parts) if parts else None


def bar(fraction: float | None, width: int = 12) -> str:
    """``[#####.......]``; empty for an unknown fraction (a run without a limit)."""
    if fraction is None:
        return ""
    filled = int(round(max(0.0, min(1.0, fraction)) * width))
    return "[" + "#" * filled + "." * (width - filled) + "] "


@dataclass(frozen=True)
class StatusFields:
    """What the status line shows; a plain record so the format is a pure function of it."""

    epoch: int
    max_epochs: int
    frames: int
    max_frames: int
    fps: float
    reward: float | None
    success: float | None
    elapsed: float
    eta: float | None


def status_line(s: StatusFields) -> str:
    """The live status line (no control characters; :class:`LiveStatus` adds them)."""
    epochs = f"epoch {s.epoch}" + (f"/{s.max_epochs}" if s.max_epochs > 0 else "")
    frames = f"frames {format_count(s.frames)}" + (f"/{format_count(s.max_frames)}" if s.max_frames > 0 else "")
    parts = [epochs, frames, f"{format_count(s.fps)} fps",
             f"reward {format_value(s.reward)}" if s.reward is not None else "reward -"]
    if s.success is not None:
        parts.append(f"success {s.success:.2f}")
    parts.append(format_duration(s.elapsed))
    parts.append(f"ETA {format_duration(s.eta)}")
    return bar(fraction_done(s.epoch, s.max_epochs, s.frames, s.max_frames)) + " | ".join(parts)


def fit(text: str, columns: int) -> str:
    """``text`` cut to ``columns - 1`` characters (a line that wraps cannot be erased in place)."""
    limit = max(columns - 1, 10)
    return text if len(text) <= limit else text[:limit - 1] + "~"


def live_wanted(setting: bool | None, stream: Any, environ: dict[str, str] | None = None) -> bool:
    """Whether the live line is shown: ``RLCHAIN_PROGRESS`` (0/off/false, 1/on/true) wins, then the
    config's ``progress.live``; unset: when ``stream`` is a terminal whose TERM is not ``dumb``."""
    env = (environ if environ is not None else os.environ).get(ENV_VAR, "").strip().lower()
    if env in ("0", "off", "false", "no"):
        return False
    if env in ("1", "on", "true", "yes"):
        return True
    if setting is not None:
        return setting
    is_tty = getattr(stream, "isatty", None)
    try:
        terminal = bool(is_tty()) if is_tty is not None else False
    except (ValueError, OSError):  # a closed or detached stream
        terminal = False
    term = (environ if environ is not None else os.environ).get("TERM", "")
    return terminal and term != "dumb"


class LiveStatus:
    """One line at the bottom of a terminal, redrawn in place; lines printed through it appear above it."""

    def __init__(self, stream: Any) -> None:
        self.stream = stream
        self.text = ""
        self.shown = False

    def _columns(self) -> int:
        return shutil.get_terminal_size((100, 24)).columns

    def show(self, text: str | None = None) -> None:
        """Draw the status (``text``, or the last one) over the current line."""
        if text is not None:
            self.text = text
        if self.text:
            self.stream.write(ERASE_LINE + fit(self.text, self._columns()))
            self.stream.flush()
            self.shown = True

    def hide(self) -> None:
        """Erase the status so the next write starts on a clean line."""
        if self.shown:
            self.stream.write(ERASE_LINE)
            self.stream.flush()
            self.shown = False

    def print(self, line: str, redraw: bool = True) -> None:
        """Print ``line`` above the status, which is redrawn under it (``redraw``; else at the next show)."""
        self.hide()
        self.stream.write(line + "\n")
        if redraw:
            self.show()
        else:
            self.stream.flush()


__all__ = ["format_duration", "format_count", "format_value", "eta_seconds", "score_eta", "run_eta", "fraction_done",
           "bar", "StatusFields",
           "status_line", "fit", "live_wanted", "LiveStatus", "ENV_VAR", "DEFAULT_LIVE_SECONDS"]
