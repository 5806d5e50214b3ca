"""``--export rl_games``: an rlchain checkpoint written as a ``.pth`` rl_games 1.6.5 / 2.0 restores."""

from __future__ import annotations

import os

import torch

from rlchain.runs import checkpoint as ckpt
from rlchain.runs import rl_games_checkpoint
from rlchain.runs.atomic import write_atomic


def export_rl_games(checkpoint: str, output: str | None = None) -> str:
    """Write ``checkpoint`` (rlchain's) in rl_games' format to ``output`` (default: the checkpoint's path
    with ``_rl_games.pth``); returns the path. A network rl_games' actor_critic cannot hold is a one-line
    CheckpointError."""
    state = ckpt.load(checkpoint, map_location="cpu")
    try:
        converted = rl_games_checkpoint.to_rl_games(state)
    except ValueError as exc:
        raise ckpt.CheckpointError(f"{checkpoint}: cannot be written for rl_games: {exc}") from None
    output = output or os.path.splitext(checkpoint)[0] + "_rl_games.pth"
    write_atomic(output, lambda fh: torch.save(converted, fh), suffix=".pth")  # as rl_games saves: no digest
    return output


__all__ = ["export_rl_games"]
