"""Record a checkpoint's episodes to mp4 (``pip install rlchain[video]``).

    from rlchain.inference.video import record_episodes
    files = record_episodes(Runner().load("cfg.yaml").params, "nn/cartpole.pth", "videos", games=2)

or ``python runner.py --play --file cfg.yaml --checkpoint nn/cartpole.pth --video videos``. The recording
itself is :mod:`rlchain.policy.recording`; during training, :class:`rlchain.training.video_callback.
VideoCallback` records in-training evaluation episodes into ``<run>/videos``.
"""

from __future__ import annotations

from rlchain.config.params import Params
from rlchain.inference.player import Player
from rlchain.policy.recording import gym_id_of, record_model_episodes, require_moviepy


def record_episodes(params: Params, checkpoint: str | None, video_dir: str, games: int = 1,
                    deterministic: bool = True) -> list[str]:
    """Load ``checkpoint`` like the Player does and record ``games`` episodes to mp4 in ``video_dir``."""

    require_moviepy()
    gym_id_of(params)  # fail on a non-gymnasium env before loading anything
    player = Player(params, checkpoint)
    try:
        return record_model_episodes(player.model, params, video_dir, games, deterministic,
                                     player.device, seed=player.seed)
    finally:
        player.close()
