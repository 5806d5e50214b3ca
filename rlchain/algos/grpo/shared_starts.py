"""GRPO's shared starts: after a reset, copy each group's first env's state into the other members.

Works on envs whose ``get_state()`` holds the batch as tensors (``{"tensors": {name: (N, ...)}, ...}``:
rlchain's :class:`~rlchain.envs.backends.tensor_env.TensorVecEnv` and EmbodiChain-contract envs built on
one); every tensor with N rows gets its leader rows repeated over the group.
"""

from __future__ import annotations

from typing import Any

import torch

from rlchain.envs.vecenv import VecEnv


def supports_shared_starts(env: VecEnv) -> bool:
    """Whether the env's state is a batch of tensors this module can copy rows of."""
    try:
        state = env.get_state()
    except Exception:  # noqa: BLE001 (any failure means: no usable state API)
        return False
    return isinstance(state, dict) and isinstance(state.get("tensors"), dict)


def leader_rows(num_envs: int, group_size: int, device: Any = None) -> torch.Tensor:
    """(N,) long: the index of each env's group leader (0, 0, 0, 0, 4, 4, ... for groups of 4)."""
    return torch.arange(num_envs, device=device) // group_size * group_size


def share_group_starts(env: VecEnv, obs: torch.Tensor, group_size: int) -> torch.Tensor:
    """Give every env its group leader's state (in the env) and observation (returned, (N, ...))."""
    n = obs.shape[0]
    state = env.get_state()
    tensors = state["tensors"]
    for name, value in tensors.items():
        if name != "all_ids" and value.dim() >= 1 and value.shape[0] == n:
            tensors[name] = value[leader_rows(n, group_size, value.device)].clone()
    env.set_state(state)
    return obs[leader_rows(n, group_size, obs.device)].clone()
