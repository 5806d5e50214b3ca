"""Stable-Baselines3's ``Logger`` as callbacks use it (``self.logger``), writing into rlchain's log writers.

``record`` / ``record_mean`` keep values until ``dump(step)``, which the SB3 face calls at SB3's log interval
(on-policy: every ``log_interval`` iterations; off-policy: every ``log_interval`` finished episodes; see
:mod:`rlchain.sb3.callbacks`) and a callback may call itself. At a dump, numbers go to every writer
(``add_scalar``: TensorBoard, wandb, CSV, ...), and SB3's other values to TensorBoard: :class:`Figure`
(``add_figure``), :class:`Image` (``add_image``), :class:`Video` (``add_video``), :class:`HParam`
(``add_hparams``, in the run's summaries folder). SB3's own classes of those names (``stable_baselines3.common.
logger``) are taken the same way. A value of no kind a writer takes is dropped with a one-line warning, once per
key. ``output_formats`` holds a TensorBoard format whose ``writer`` is the run's SummaryWriter (SB3's tensorboard
guide reaches it directly: ``writer.add_text(...)``); it is an instance of SB3's ``TensorBoardOutputFormat`` when
stable-baselines3 is imported, so the guide's ``isinstance`` check finds it.
"""

from __future__ import annotations

import sys
from collections import defaultdict
from typing import Any

import numpy as np

from rlchain.log import get_logger

log = get_logger(__name__)


class Figure:
    """A matplotlib figure to log (``close``: close it once written)."""

    def __init__(self, figure: Any, close: bool) -> None:
        self.figure, self.close = figure, close


class Image:
    """An image to log: a tensor or array in ``dataformats`` (``'HWC'``, ``'CHW'``, ...)."""

    def __init__(self, image: Any, dataformats: str) -> None:
        self.image, self.dataformats = image, dataformats


class Video:
    """A video to log: frames (N, T, C, H, W) and frames per second."""

    def __init__(self, frames: Any, fps: float) -> None:
        self.frames, self.fps = frames, fps


class HParam:
    """Hyperparameters and the metrics to show beside them in TensorBoard's HPARAMS tab."""

    def __init__(self, hparam_dict: dict[str, Any], metric_dict: dict[str, Any]) -> None:
        if not metric_dict:
            raise ValueError("HParam: metric_dict must name at least one metric, as SB3 requires")
        self.hparam_dict, self.metric_dict = hparam_dict, metric_dict


def _kind(value: Any) -> str | None:
    """Which SB3 record ``value`` is (ours or SB3's own class of the name), else None."""
    name = type(value).__name__
    fields = {"Figure": ("figure", "close"), "Image": ("image", "dataformats"), "Video": ("frames", "fps"),
              "HParam": ("hparam_dict", "metric_dict")}
    if name in fields and all(hasattr(value, f) for f in fields[name]):
        return name
    return None


class _Proxy:
    """The run's SummaryWriter as SB3's ``TensorBoardOutputFormat.writer``: any SummaryWriter call, to the writer
    of the run going on (nothing between runs)."""

    def __init__(self, logger: SB3Logger) -> None:
        self._logger = logger

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        writer = self._logger.writer
        return (lambda *args, **kwargs: None) if writer is None else getattr(writer, name)


class TensorBoardOutputFormat:
    """SB3's TensorBoard output format: ``writer`` is the run's SummaryWriter."""

    def __init__(self, writer: Any) -> None:
        self.writer = writer

    def close(self) -> None:
        """The run owns the writer."""


def tensorboard_format(writer: Any) -> Any:
    """A TensorBoard output format around ``writer``: SB3's own class when stable-baselines3 is imported (made
    without its constructor, which would open a second event file), else :class:`TensorBoardOutputFormat`."""
    sb3_logger = sys.modules.get("stable_baselines3.common.logger")
    cls = getattr(sb3_logger, "TensorBoardOutputFormat", None)
    if isinstance(cls, type):
        fmt = cls.__new__(cls)
        fmt.writer, fmt._is_closed = writer, False
        return fmt
    return TensorBoardOutputFormat(writer)


class SB3Logger:
    """See the module docstring. ``writer``: the run's writer while a run is going (None otherwise);
    ``name_to_value`` holds what was recorded since the last dump."""

    def __init__(self, folder: str | None = None) -> None:
        self.name_to_value: dict[str, Any] = defaultdict(float)
        self.name_to_count: dict[str, int] = defaultdict(int)
        self.name_to_excluded: dict[str, tuple[str, ...]] = {}
        self.level = 20
        self.dir = folder
        self.writer: Any = None
        self._warned: set[str] = set()
        self._format: Any = None

    @property
    def output_formats(self) -> list[Any]:
        """A TensorBoard format whose ``writer`` is the run's SummaryWriter (:func:`tensorboard_format`)."""
        if self._format is None:
            self._format = tensorboard_format(_Proxy(self))
        return [self._format]

    def record(self, key: str, value: Any, exclude: str | tuple[str, ...] | None = None) -> None:
        """Keep ``value`` under ``key`` until the next :meth:`dump`."""
        self.name_to_value[key] = value
        self.name_to_excluded[key] = (exclude,) if isinstance(exclude, str) else tuple(exclude or ())

    def record_mean(self, key: str, value: float | None, exclude: str | tuple[str, ...] | None = None) -> None:
        """Keep the running mean of the values recorded under ``key`` until the next :meth:`dump`."""
        if value is None:
            return
        old, count = self.name_to_value[key], self.name_to_count[key]
        self.name_to_value[key] = old * count / (count + 1) + value / (count + 1)
        self.name_to_count[key] = count + 1
        self.name_to_excluded[key] = (exclude,) if isinstance(exclude, str) else tuple(exclude or ())

    def dump(self, step: int = 0) -> None:
        """Write what was recorded at ``step`` (env frames) and forget it."""
        if self.writer is not None:
            for key, value in self.name_to_value.items():
                if "tensorboard" not in self.name_to_excluded.get(key, ()):
                    self._write(key, value, int(step))
        self.name_to_value.clear()
        self.name_to_count.clear()
        self.name_to_excluded.clear()

    def _write(self, key: str, value: Any, step: int) -> None:
        if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
            self.writer.add_scalar(key, float(value), step)
            return
        if hasattr(value, "dim") and hasattr(value, "item") and value.dim() == 0:  # a 0-dim tensor: a number
            self.writer.add_scalar(key, float(value.item()), step)
            return
        try:
            self._write_other(key, value, step)
        except Exception as exc:  # a writer's optional dependency (moviepy for videos, matplotlib) or bad data
            if key not in self._warned:
                self._warned.add(key)
                log.warning(f"warning: logger.record('{key}', ...) not written: {type(exc).__name__}: "
                            f"{' '.join(str(exc).split())[:160]}")

    def _write_other(self, key: str, value: Any, step: int) -> None:
        kind = _kind(value)
        if kind == "Figure":
            self.writer.add_figure(key, value.figure, step, close=value.close)
        elif kind == "Image":
            self.writer.add_image(key, value.image, step, dataformats=value.dataformats)
        elif kind == "Video":
            self.writer.add_video(key, value.frames, step, fps=value.fps)
        elif kind == "HParam":
            self.writer.add_hparams(value.hparam_dict, value.metric_dict, run_name=".")
        elif isinstance(value, str):
            self.writer.add_text(key, value, step)
        elif key not in self._warned:
            self._warned.add(key)
            log.warning(f"warning: logger.record('{key}', ...): a {type(value).__name__} is not written (numbers, "
                        f"strings, Figure, Image, Video, HParam are)")

    def get_dir(self) -> str | None:
        """The run folder (None before the first run)."""
        return self.dir

    def set_level(self, level: int) -> None:
        """SB3's verbosity level (kept; rlchain logs through its own writers)."""
        self.level = level

    def log(self, *args: Any, level: int = 20) -> None:
        """Print ``args`` when ``level`` is at least the logger's."""
        if level >= self.level:
            print(*args, flush=True)

    def debug(self, *args: Any) -> None:
        self.log(*args, level=10)

    def info(self, *args: Any) -> None:
        self.log(*args, level=20)

    def warn(self, *args: Any) -> None:
        self.log(*args, level=30)

    def error(self, *args: Any) -> None:
        self.log(*args, level=40)

    def close(self) -> None:
        """Nothing to close: the run owns the writers."""
