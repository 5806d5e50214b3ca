"""A callback that records one episode every N-th in-training evaluation (``pip install rlchain[video]``).

    from rlchain.training.video_callback import VideoCallback
    Runner().load("cfg.yaml").train(callbacks=[VideoCallback(every_n_evaluations=5)])

needs ``config.evaluation.interval`` > 0; the recording is :mod:`rlchain.policy.recording`'s.
"""

from __future__ import annotations

import os
from typing import Any

from rlchain.log import get_logger
from rlchain.policy.recording import record_model_episodes, require_moviepy
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback

log = get_logger(__name__)


class VideoCallback(Callback):
    """Records one episode every ``every_n_evaluations``-th in-training evaluation.

    Videos go to ``video_dir`` (default ``<run folder>/videos``), named ``epoch_<N>-episode-0.mp4``.
    """

    def __init__(self, every_n_evaluations: int = 1, video_dir: str | None = None,
                 deterministic: bool = True) -> None:
        if every_n_evaluations < 1:
            raise ValueError("every_n_evaluations must be >= 1")
        require_moviepy()
        self.every = every_n_evaluations
        self.video_dir = video_dir
        self.deterministic = deterministic
        self.count = 0
        self.files: list[str] = []

    def on_evaluation(self, ctx: CallbackContext, result: Any) -> None:
        self.count += 1
        if self.count % self.every != 0:
            return
        state = ctx.state
        folder = self.video_dir or os.path.join(state.experiment_dir or ".", "videos")
        files = record_model_episodes(ctx.model, ctx.params, folder, 1, self.deterministic,
                                      state.device, seed=state.seed, name_prefix=f"epoch_{state.epoch}")
        self.files.extend(files)
        if ctx.params.config.print_stats:
            log.info(f"video at epoch {state.epoch}: {', '.join(files)}")
