"""``--export onnx`` for ``config.multi_agent``: one ONNX graph per policy (``--policy NAME``: one).

Each graph is the policy's deterministic policy exactly as :mod:`rlchain.inference.export.onnx` documents it
(obs -> action, value; ``action_mask`` input for masked policies), fed with that policy's agents'
flat observations. The files are ``<output base>_<policy>.onnx`` (``<checkpoint base>`` when no
``--output`` is given); with ``--policy`` the output path is used as it is. Each graph's parity
with PyTorch is checked on random observations and on observations of the policy's agents in the env.
"""

from __future__ import annotations

import os
import warnings
from typing import Any

import numpy as np
import torch

from rlchain.config.errors import ConfigError
from rlchain.inference.export.inputs import random_observations
from rlchain.inference.export.onnx import _require, default_output_path, export_model_onnx, onnx_session, verify_onnx
from rlchain.models.build import policy_agents
from rlchain.policy.load import load_policy
from rlchain.policy.play import step_policies


def policy_output_path(output: str, policy: str) -> str:
    """``runs/x/nn/x.onnx`` + ``predator`` -> ``runs/x/nn/x_predator.onnx``."""
    base, ext = os.path.splitext(output)
    return f"{base}_{policy}{ext or '.onnx'}"


def export_policies(params: Any, checkpoint: str, output: str | None = None, policy: str | None = None,
                    opset: int = 17, num_random: int = 64, env_steps: int = 8) -> list[str]:
    """Export every policy of ``checkpoint`` (or only ``policy``) to ONNX; returns the paths."""

    _require("onnx")
    _require("onnxruntime")
    if policy is not None and policy not in params.policies:
        raise ConfigError(params.source, "--policy", f"unknown policy '{policy}' (policies: "
                                                     f"{', '.join(params.policies)})")
    seed = params.seed if params.seed is not None else 0
    loaded = load_policy(params, checkpoint, device=torch.device("cpu"), num_envs=2, seed=seed,
                         env_config=params.config.player.env_config, eval_mode=False)  # each model: eval below
    env, models = loaded.env, loaded.model
    try:
        plan = {name: agents for name, agents in policy_agents(params, env).items() if agents}
        if policy is not None and policy not in plan:
            raise ConfigError(params.source, "--policy", f"policy '{policy}' plays no agent of this env")
        observed = _env_observations(env, models, plan, env_steps, seed)
        names = [policy] if policy is not None else list(plan)
        base = output or default_output_path(checkpoint)
        paths = []
        for name in names:
            model = models[name].eval()
            path = output if (policy is not None and output) else policy_output_path(base, name)
            space = env.observation_spaces[plan[name][0]]
            export_model_onnx(model, tuple(space.shape), path, opset, torch.float32)
            session = onnx_session(path)
            random_diff = verify_onnx(model, path, random_observations(space, num_random, seed), session, seed=seed)
            obs, masks = observed[name]
            real_diff = verify_onnx(model, path, obs, session, masks=masks if model.use_action_masks else None)
            print(f"exported ONNX policy '{name}' to {path}; onnxruntime parity: max abs diff {random_diff:.2e} "
                  f"on {num_random} random observations, {real_diff:.2e} on {len(obs)} env observations",
                  flush=True)
            if max(random_diff, real_diff) > 1e-4:
                warnings.warn(f"ONNX output of policy {name} differs from PyTorch by "
                              f"{max(random_diff, real_diff):.2e}", stacklevel=2)
            paths.append(path)
        return paths
    finally:
        env.close()


def _env_observations(env: Any, models: Any, plan: dict[str, list[str]], steps: int, seed: int
                      ) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    """Each policy's active observations (and masks) over ``steps`` steps of the deterministic policies."""
    seen: dict[str, list] = {name: [] for name in plan}
    masks_seen: dict[str, list] = {name: [] for name in plan}

    def record(name: str, agent_views: list[Any], obs: np.ndarray, masks: np.ndarray | None) -> None:
        active = np.concatenate([view.active for view in agent_views])
        seen[name].append(obs[active])
        if masks is not None:
            masks_seen[name].append(masks[active])

    stepping = step_policies(env, models, plan, torch.device("cpu"), True, seed, on_obs=record)
    for _ in range(steps):
        next(stepping)
    return {name: (np.concatenate(seen[name]), np.concatenate(masks_seen[name]) if masks_seen[name] else None)
            for name in plan}
