"""Checkpoints: atomic writes, exact resume state, and clear errors for bad files."""

from __future__ import annotations

import os
import random
import tempfile
from typing import Any

import numpy as np
import torch

from rlchain.runs import rl_games_checkpoint

FORMAT = "rlchain-checkpoint-1"


class CheckpointError(RuntimeError):
    """A checkpoint that cannot be read or does not fit the model."""


def save_atomic(state: dict[str, Any], path: str) -> None:
    """Write ``state`` to ``path`` through a temp file + rename: a crash never leaves half a file."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp_", suffix=".pth", dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            torch.save(state, fh)
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a checkpoint is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def load(path: str, map_location: str | torch.device = "cpu") -> dict[str, Any]:
    """Read a checkpoint written by rlchain; any other file is a one-line CheckpointError."""
    if not os.path.isfile(path):
        raise CheckpointError(f"{path}: checkpoint not found")
    try:
        state = torch.load(path, map_location=map_location, weights_only=False)
    except Exception as exc:  # torch raises many types for a corrupt file
        raise CheckpointError(f"{path}: not a readable checkpoint ({type(exc).__name__}: "
                              f"{' '.join(str(exc).split())[:200]})") from None
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        if rl_games_checkpoint.is_rl_games_checkpoint(state):  # rl_games 1.6.5 / 2.0: read as rlchain's
            try:
                return {**rl_games_checkpoint.from_rl_games(state), "format": FORMAT}
            except ValueError as exc:
                raise CheckpointError(f"{path}: an rl_games checkpoint rlchain cannot read: {exc}") from None
        raise CheckpointError(f"{path}: not an rlchain checkpoint (no '{FORMAT}' marker)")
    return state


def load_model_state(model: torch.nn.Module, state: dict[str, Any], path: str) -> None:
    """Load weights, naming the first parameter whose name or shape does not match."""
    own = model.state_dict()
    saved = state["model"]
    missing = [k for k in own if k not in saved]
    unexpected = [k for k in saved if k not in own]
    if missing or unexpected:
        detail = f"missing {missing[:3]}" if missing else f"unexpected {unexpected[:3]}"
        raise CheckpointError(f"{path}: checkpoint does not match this model's network ({detail}); "
                              f"was it trained with another config?")
    for key, value in saved.items():
        if tuple(value.shape) != tuple(own[key].shape):
            raise CheckpointError(f"{path}: parameter '{key}' has shape {tuple(value.shape)} in the "
                                  f"checkpoint but {tuple(own[key].shape)} in this model")
    model.load_state_dict(saved)


def rng_state() -> dict[str, Any]:
    """All random generator states, so a resumed run draws the same numbers."""
    state = {"python": random.getstate(), "numpy": np.random.get_state(), "torch": torch.get_rng_state()}
    if torch.cuda.is_available():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def set_rng_state(state: dict[str, Any]) -> None:
    random.setstate(state["python"])
    np.random.set_state(state["numpy"])
    torch.set_rng_state(state["torch"].cpu())
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all([s.cpu() for s in state["cuda"]])


def seed_everything(seed: int) -> None:
    """Seed python, numpy and torch (CPU and CUDA)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
