"""TensorBoard tags as rl_games writes them, plus the console progress line, for any algorithm."""

from __future__ import annotations

import math
import sys
import time
from typing import Any

from rlchain.config.run import ProgressConfig
from rlchain.log import get_logger
from rlchain.runs.rl_games_layout import RlGamesTags
from rlchain.runs.writers import ConsoleWriter, EpochSummary, Step, TensorBoardWriter, Writer

log = get_logger(__name__)


class TrainLogger:
    """Writes rl_games' TensorBoard tags (rewards/step|iter|time, performance/*, info/epochs), the
    algorithm's own (losses/*, info/*: the tags its ``metric_tags`` name) and, for envs that report
    task success, ``episodes/success_rate`` -- through every log writer (rlchain/runs/writers.py):
    the console line (``print_stats``; ``progress``: its live status on a terminal), TensorBoard
    (``summaries_dir``) and ``writers`` (wandb, the config's ``log_writers``). :attr:`last_scalars` holds
    the last epoch's, for callbacks."""

    def __init__(self, summaries_dir: str | None, print_stats: bool = True, stream: Any = None,
                 writers: list[Writer] | None = None, progress: ProgressConfig | None = None,
                 rl_games: RlGamesTags | None = None) -> None:
        self.tensorboard = TensorBoardWriter(summaries_dir) if summaries_dir is not None else None
        self.print_stats = print_stats
        self.stream = stream or sys.stdout
        # no progress block (tests, tuning's loggers): plain lines, never the live status
        progress = self.progress = progress if progress is not None else ProgressConfig(live=False)
        console = [ConsoleWriter(self.stream, progress)] if print_stats else []
        self.writers: list[Writer] = [*console, *([self.tensorboard] if self.tensorboard else []), *(writers or [])]
        self.start = time.time()
        self.frames = self.epochs = 0
        self.last_scalars: dict[str, float] = {}
        self.rl_games = rl_games
        """Given for runs through rl_games' API: rl_games' extra tags, scalars at the frames before the epoch."""

    def moved(self, summaries_dir: str, writers: list[Writer]) -> TrainLogger:
        """A logger like this one (its console, progress and rl_games' tags) that writes TensorBoard into another
        run folder's ``summaries_dir`` and through ``writers`` (that folder's own)."""
        return TrainLogger(summaries_dir, self.print_stats, self.stream, writers, self.progress, self.rl_games)

    @property
    def writer(self) -> Any:
        """The TensorBoard SummaryWriter (None without a run folder or after a failed write)."""
        return self.tensorboard.summary_writer if self.tensorboard is not None else None

    def scalar(self, tag: str, value: float, step: int) -> None:
        """One scalar at the x value ``step``, to every writer."""
        self.emit({tag: float(value)}, self._step(at=step))

    def emit(self, scalars: dict[str, float], step: Step) -> None:
        for writer in self.writers:
            writer.write(scalars, step)

    def _step(self, at: float | None = None) -> Step:
        return Step(self.frames, self.epochs, time.time() - self.start, at)

    def write(self, method: str, *args: Any, **kwargs: Any) -> None:
        """A SummaryWriter call (callbacks' ``ctx.writer``): ``add_scalar`` goes to every writer, other
        methods (histograms, text ...) to TensorBoard only."""
        if method == "add_scalar":
            names = ("tag", "scalar_value", "global_step")
            bound = {**dict(zip(names, args)), **{k: v for k, v in kwargs.items() if k in names}}
            step = bound.get("global_step")
            self.scalar(bound["tag"], bound["scalar_value"], self.frames if step is None else step)
        elif self.tensorboard is not None:
            self.tensorboard.call(method, *args, **kwargs)

    def epoch(self, epoch: int, max_epochs: int, frames: int, metrics: dict[str, float],
              episodes: dict[str, float] | None, best: float, timing: dict[str, float],
              console: list[str] | tuple[str, ...] = (), max_frames: int = 0,
              score_to_win: float = math.inf) -> None:
        """Log one epoch: timing and fps, the algorithm's ``{tag: value}`` metrics, ``info/epochs`` and
        the episode means when games finished; ``console``: the algorithm's fields of the epoch line;
        ``max_epochs`` / ``max_frames``: the run's limits (<= 0: none), for the line and the live ETA;
        ``score_to_win``: the score that stops the run (its ETA from the reward's trend)."""
        seconds = time.time() - self.start
        batch = timing["batch"]
        step_fps = batch / max(timing["rollout"], 1e-9)
        total_fps = batch / max(timing["rollout"] + timing["update"], 1e-9)
        scalars = {"performance/step_fps": step_fps, "performance/step_inference_rl_update_fps": total_fps,
                   "performance/rl_update_time": timing["update"], "performance/step_time": timing["rollout"],
                   **{tag: float(value) for tag, value in metrics.items()}, "info/epochs": epoch}
        if episodes is not None:  # each value at frames, epochs and whole seconds (Step.x), as rl_games
            for name, value in (("rewards", episodes["reward"]), ("episode_lengths", episodes["length"])):
                scalars.update({f"{name}/step": value, f"{name}/iter": value, f"{name}/time": value})
            if "success" in episodes:  # envs that report task success (rlchain/envs/wrappers/success.py)
                scalars["episodes/success_rate"] = episodes["success"]
        self.frames, self.epochs = frames, epoch
        axis = frames
        if self.rl_games is not None:
            scalars.update(self.rl_games.scalars(episodes, step_fps))
            axis = max(0, frames - batch)  # rl_games counts an epoch's frames after writing its scalars
        self.last_scalars = {tag: float(value) for tag, value in scalars.items()}
        self.emit(self.last_scalars, Step(axis, epoch, seconds))
        summary = EpochSummary(epoch, max_epochs, frames, seconds, total_fps, step_fps,
                               episodes["reward"] if episodes is not None else None,
                               episodes["length"] if episodes is not None else None,
                               episodes.get("success") if episodes is not None else None, best, tuple(console),
                               max_frames, score_to_win)
        for writer in self.writers:
            writer.epoch_end(summary)

    def flush(self) -> None:
        for writer in self.writers:
            writer.flush()

    def close(self) -> None:
        for writer in self.writers:
            writer.close()
