"""A trained policy from its checkpoint: the env it plays on (built here unless given) and its model with
the checkpoint's weights. The Player, watch, video, ONNX export, the multi-policy player and export, the
distill teacher, rl_games' player and the SB3 face's models all load a policy through :func:`load_policy` /
:func:`load_weights`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch

from rlchain.config.params import Params
from rlchain.envs.factory import build_env
from rlchain.envs.vecenv import VecEnv
from rlchain.models.build import apply_sigma, build_model
from rlchain.parallel.device import resolve_device
from rlchain.runs import checkpoint as ckpt


@dataclass
class LoadedPolicy:
    """A policy ready to play: ``model`` (a ModuleDict of one model per policy with config.multi_agent) on
    ``device``, the ``env`` it was built for, and the checkpoint ``state`` read (None without one)."""

    model: torch.nn.Module
    env: VecEnv
    device: torch.device
    state: dict[str, Any] | None
    owns_env: bool = True

    def close(self) -> None:
        """Close the env when :func:`load_policy` built it."""
        if self.owns_env:
            self.env.close()


def load_policy(params: Params, checkpoint: str | None = None, *, device: str | torch.device | None = None,
                env: VecEnv | None = None, num_envs: int = 1, seed: int | None = None, render: bool = False,
                env_config: dict | None = None, sigma: float | None = None, state: dict[str, Any] | None = None,
                group: str | None = None, groups: Any = None, eval_mode: bool = True) -> LoadedPolicy:
    """The model of ``params`` with ``checkpoint``'s weights, on ``env`` or on ``num_envs`` envs built here.

    The checkpoint is read first (``state`` when the caller read it already), so a bad file fails before
    any env opens; an env built here is closed again when the model cannot be built or loaded. ``device``:
    default ``params.config.device``; ``seed``: default ``params.seed`` (0 without one); ``group`` /
    ``groups``: the observation group the model reads (see :func:`rlchain.models.build.model_view`);
    ``sigma``: ``--sigma``, a fixed std for a continuous policy. The model is put in eval mode unless
    ``eval_mode`` is False.
    """
    device = device if isinstance(device, torch.device) else resolve_device(device or params.config.device)
    if state is None and checkpoint:
        state = ckpt.load(checkpoint, map_location=device)
    owns_env = env is None
    if owns_env:
        seed = seed if seed is not None else params.seed if params.seed is not None else 0
        env = build_env(params, num_envs, seed, render=render, env_config=env_config)
    try:
        model = build_model(params, env, device, group=group, groups=groups)
        if state is not None:
            ckpt.load_model_state(model, state, checkpoint or "<checkpoint>")
        if sigma is not None:
            apply_sigma(model, sigma)
    except BaseException:
        if owns_env:
            env.close()
        raise
    if eval_mode:
        model.eval()
    return LoadedPolicy(model, env, device, state, owns_env)


def load_weights(model: torch.nn.Module, checkpoint: str, device: torch.device | str = "cpu") -> dict[str, Any]:
    """Load ``checkpoint``'s weights into an already built ``model`` (a mismatch is a CheckpointError);
    returns the checkpoint's state."""
    state = ckpt.load(checkpoint, map_location=device)
    ckpt.load_model_state(model, state, checkpoint)
    return state
