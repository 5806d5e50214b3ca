"""TensorBoard tags as rl_games writes them, plus the console progress line, for any algorithm."""

from __future__ import annotations

import math
import sys
import time
from typing import Any

from rlchain.log import get_logger
from rlchain.training.events import Callback

log = get_logger(__name__)


class EnvStatsCallback(Callback):
    """Writes an env backend's counters, ``env.log_stats()`` (e.g. ``env/dropped_episodes``), every epoch."""

    drives_trainer = True  # reads the training env itself

    def on_epoch_end(self, trainer: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        for tag, value in trainer.env.log_stats().items():
            trainer.logger.scalar(tag, float(value), trainer.frames)


class TrainLogger:
    """Writes rl_games' TensorBoard tags (rewards/step|iter|time, performance/*, info/epochs), the
    algorithm's own (losses/*, info/*: the tags its ``metric_tags`` name) and, for envs that report
    task success, ``episodes/success_rate``."""

    def __init__(self, summaries_dir: str | None, print_stats: bool = True, stream: Any = None) -> None:
        self.writer = None
        if summaries_dir is not None:
            from torch.utils.tensorboard import SummaryWriter
            self.writer = SummaryWriter(summaries_dir, flush_secs=10)
        self.print_stats = print_stats
        self.stream = stream or sys.stdout
        self.start = time.time()

    def scalar(self, tag: str, value: float, step: int) -> None:
        self.write("add_scalar", tag, value, step)

    def write(self, method: str, *args: Any, **kwargs: Any) -> None:
        """Call a SummaryWriter method (nothing without a writer); a failed write disables logging
        with one warning."""
        if self.writer is not None:
            try:
                getattr(self.writer, method)(*args, **kwargs)
            except OSError as exc:
                self._writer_failed(exc)

    def _writer_failed(self, exc: OSError) -> None:
        """A failed log write is reported once; training goes on without TensorBoard logs."""
        log.warning(f"warning: TensorBoard log write failed ({exc.strerror or exc}); training goes on without "
                    f"logs, checkpoints are unaffected")
        self.writer = None

    def epoch(self, epoch: int, max_epochs: int, frames: int, metrics: dict[str, float],
              episodes: dict[str, float] | None, best: float, timing: dict[str, float],
              console: list[str] | tuple[str, ...] = ()) -> None:
        """Log one epoch: timing and fps, the algorithm's ``{tag: value}`` metrics, ``info/epochs`` and
        the episode means when games finished; ``console``: the algorithm's fields of the epoch line."""
        elapsed = int(time.time() - self.start)
        batch = timing["batch"]
        step_fps = batch / max(timing["rollout"], 1e-9)
        total_fps = batch / max(timing["rollout"] + timing["update"], 1e-9)
        s = self.scalar
        s("performance/step_fps", step_fps, frames)
        s("performance/step_inference_rl_update_fps", total_fps, frames)
        s("performance/rl_update_time", timing["update"], frames)
        s("performance/step_time", timing["rollout"], frames)
        for tag, value in metrics.items():
            s(tag, value, frames)
        s("info/epochs", epoch, frames)
        if episodes is not None:
            for name, value in (("rewards", episodes["reward"]), ("episode_lengths", episodes["length"])):
                s(f"{name}/step", value, frames)
                s(f"{name}/iter", value, epoch)
                s(f"{name}/time", value, elapsed)
            if "success" in episodes:  # envs that report task success (rlchain/envs/wrappers/success.py)
                s("episodes/success_rate", episodes["success"], frames)
        if self.print_stats:
            limit = f"/{max_epochs}" if max_epochs > 0 else ""
            reward = f"{episodes['reward']:.2f}" if episodes is not None else "-"
            length = f"{episodes['length']:.1f}" if episodes is not None else "-"
            best_text = f"{best:.2f}" if math.isfinite(best) else "-"
            if episodes is not None and "success" in episodes:
                console = [f"success {episodes['success']:.2f}", *console]
            fields = "".join(f" | {field}" for field in console)
            print(f"epoch {epoch}{limit} | frames {frames} | fps {total_fps:.0f} (step {step_fps:.0f}) | "
                  f"reward {reward} | best {best_text} | len {length}{fields} | {elapsed}s",
                  file=self.stream, flush=True)

    def flush(self) -> None:
        self.write("flush")

    def close(self) -> None:
        self.write("close")
