"""TensorBoard tags as rl_games writes them, plus the console progress line."""

from __future__ import annotations

import math
import sys
import time
from typing import Any

from rlchain.training.events import Callback


class EnvStatsCallback(Callback):
    """Writes an env backend's counters, ``env.log_stats()`` (e.g. ``env/dropped_episodes``), every epoch."""

    def on_epoch_end(self, trainer: Any, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        for tag, value in trainer.env.log_stats().items():
            trainer.logger.scalar(tag, float(value), trainer.frames)


class TrainLogger:
    """Writes rl_games' TensorBoard tags (rewards/step|iter|time, losses/*, info/*, performance/*)."""

    def __init__(self, summaries_dir: str | None, print_stats: bool = True, stream: Any = None) -> None:
        self.writer = None
        if summaries_dir is not None:
            from torch.utils.tensorboard import SummaryWriter
            self.writer = SummaryWriter(summaries_dir, flush_secs=10)
        self.print_stats = print_stats
        self.stream = stream or sys.stdout
        self.start = time.time()

    def scalar(self, tag: str, value: float, step: int) -> None:
        self._write("add_scalar", tag, value, step)

    def _write(self, method: str, *args: object) -> None:
        """Call a SummaryWriter method; a failed write disables logging with one warning."""
        if self.writer is not None:
            try:
                getattr(self.writer, method)(*args)
            except OSError as exc:
                self._writer_failed(exc)

    def _writer_failed(self, exc: OSError) -> None:
        """A failed log write is reported once; training goes on without TensorBoard logs."""
        print(f"warning: TensorBoard log write failed ({exc.strerror or exc}); training goes on without "
              f"logs, checkpoints are unaffected", file=self.stream, flush=True)
        self.writer = None

    def epoch(self, epoch: int, max_epochs: int, frames: int, stats: dict[str, float],
              episodes: dict[str, float] | None, best: float, timing: dict[str, float]) -> None:
        """Log one epoch: losses and lr, timing and fps, and episode means when games finished."""
        elapsed = int(time.time() - self.start)
        batch = timing["batch"]
        step_fps = batch / max(timing["rollout"], 1e-9)
        total_fps = batch / max(timing["rollout"] + timing["update"], 1e-9)
        s = self.scalar
        s("performance/step_fps", step_fps, frames)
        s("performance/step_inference_rl_update_fps", total_fps, frames)
        s("performance/rl_update_time", timing["update"], frames)
        s("performance/step_time", timing["rollout"], frames)
        s("losses/a_loss", stats["a_loss"], frames)
        s("losses/c_loss", stats["c_loss"], frames)
        s("losses/entropy", stats["entropy"], frames)
        s("losses/bounds_loss", stats["b_loss"], frames)
        for tag, value in stats.items():
            if tag.startswith("losses/"):  # the network's auxiliary losses (get_aux_loss), rl_games' tags
                s(tag, value, frames)
        s("info/last_lr", stats["lr"], frames)
        s("info/lr_mul", stats["lr"] / max(stats.get("lr0", stats["lr"]), 1e-12), frames)
        s("info/kl", stats["kl"], frames)
        if "entropy_coef" in stats:  # rlchain: rl_games writes no tag for it
            s("info/entropy_coef", stats["entropy_coef"], frames)
        s("info/epochs", epoch, frames)
        s("info/clip_frac", stats["clip_frac"], frames)
        s("info/grad_norm", stats["grad_norm"], frames)
        if episodes is not None:
            for name, value in (("rewards", episodes["reward"]), ("episode_lengths", episodes["length"])):
                s(f"{name}/step", value, frames)
                s(f"{name}/iter", value, epoch)
                s(f"{name}/time", value, elapsed)
        if self.print_stats:
            limit = f"/{max_epochs}" if max_epochs > 0 else ""
            reward = f"{episodes['reward']:.2f}" if episodes is not None else "-"
            length = f"{episodes['length']:.1f}" if episodes is not None else "-"
            best_text = f"{best:.2f}" if math.isfinite(best) else "-"
            print(f"epoch {epoch}{limit} | frames {frames} | fps {total_fps:.0f} (step {step_fps:.0f}) | "
                  f"reward {reward} | best {best_text} | len {length} | kl {stats['kl']:.4f} | "
                  f"lr {stats['lr']:.2e} | {elapsed}s", file=self.stream, flush=True)

    def flush(self) -> None:
        self._write("flush")

    def close(self) -> None:
        self._write("close")
