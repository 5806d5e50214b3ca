"""EmbodiChain's TensorBoard tags beside rlchain's, for runs read from an EmbodiChain config (the reader adds
this callback): per-term rewards ``rewards/<term>`` and ``metrics/<name>`` from the env's ``info`` (means over
the epoch's steps), ``charts/SPS``, ``charts/episode_reward_avg_100``, ``charts/episode_length_avg_100``,
``train/<stat>`` (the update's statistics under rlchain's raw names), and ``eval/avg_reward``,
``eval/avg_length``, ``eval/success_rate`` after each in-training evaluation. x axis: env steps."""

from __future__ import annotations

from typing import Any

import torch

from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback


class EmbodiChainTags(Callback):
    """Writes EmbodiChain's tags (see the module docstring) through the run's writer."""

    def __init__(self) -> None:
        self.sums: dict[str, float] = {}
        self.counts: dict[str, int] = {}

    def on_env_step(self, ctx: CallbackContext, result: Any, done_indices: Any, rows: slice) -> None:
        infos = result.infos if isinstance(result.infos, dict) else {}
        for group in ("rewards", "metrics"):
            terms = infos.get(group)
            if not isinstance(terms, dict):
                continue
            for name, value in terms.items():
                tag = f"{group}/{name}"
                mean = value.float().mean() if isinstance(value, torch.Tensor) else float(value)
                self.sums[tag] = self.sums.get(tag, 0.0) + float(mean)
                self.counts[tag] = self.counts.get(tag, 0) + 1

    def on_epoch_end(self, ctx: CallbackContext, stats: dict[str, float], episodes: dict[str, float] | None) -> None:
        state, write = ctx.state, ctx.writer.add_scalar
        for tag, total in self.sums.items():
            write(tag, total / self.counts[tag], state.frames)
        self.sums, self.counts = {}, {}
        write("charts/SPS", state.frames / max(state.seconds, 1e-6), state.frames)
        if episodes:
            if "reward" in episodes:
                write("charts/episode_reward_avg_100", episodes["reward"], state.frames)
            if "length" in episodes:
                write("charts/episode_length_avg_100", episodes["length"], state.frames)
        for key, value in stats.items():
            if isinstance(value, (int, float)):
                write(f"train/{key}", float(value), state.frames)

    def on_evaluation(self, ctx: CallbackContext, result: Any) -> None:
        write, frames = ctx.writer.add_scalar, ctx.state.frames
        write("eval/avg_reward", result.mean_reward, frames)
        write("eval/avg_length", result.mean_length, frames)
        if result.success_rate is not None:
            write("eval/success_rate", result.success_rate, frames)
