"""Inputs for the ONNX parity check (:func:`rlchain.inference.export.onnx.verify_onnx`): observations and action masks.

Random ones cover the whole observation space and every mask pattern; env ones are what a deployed
policy meets. Shapes: observations (n, *obs_shape), masks (n, mask_size) bool.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.policy.play import play

RANDOM_OBS_BOUND = 10.0
"""Random parity observations: an unbounded side of a Box dim (inf, or beyond +-1e6 like CartPole's
float32-max velocity bounds) is replaced so the dim spans 2 * RANDOM_OBS_BOUND (-10..10 when both
sides are unbounded)."""
HUGE_BOUND = 1e6


def random_observations(space: gym.Space, n: int, seed: int = 0) -> np.ndarray:
    """``n`` observations drawn uniformly inside ``space``'s bounds, unbounded sides made finite."""
    if isinstance(space, gym.spaces.Dict):  # kept per key: {key: (n, *shape)} in each key's dtype
        return {k: random_observations(s, n, seed + i) for i, (k, s) in enumerate(space.spaces.items())}
    rng = np.random.default_rng(seed)
    if isinstance(space, gym.spaces.Box):
        shape = (n, *space.shape)
        if np.dtype(space.dtype) == np.uint8:
            return rng.integers(space.low, space.high.astype(np.int64) + 1, size=shape).astype(np.uint8)
        low, high = space.low.astype(np.float64), space.high.astype(np.float64)
        low_ok = np.isfinite(low) & (np.abs(low) <= HUGE_BOUND)
        high_ok = np.isfinite(high) & (np.abs(high) <= HUGE_BOUND)
        span = 2 * RANDOM_OBS_BOUND
        low = np.where(low_ok, low, np.where(high_ok, high - span, -RANDOM_OBS_BOUND))
        high = np.where(high_ok, high, low + span)
        return rng.uniform(low, high, size=shape).astype(np.float32)
    space.seed(seed)
    dtype = np.int64 if isinstance(space, (gym.spaces.Discrete, gym.spaces.MultiDiscrete)) else np.float32
    return np.stack([np.asarray(space.sample(), dtype=dtype) for _ in range(n)])


def random_masks(dist: Any, n: int, seed: int = 0) -> np.ndarray:
    """(n, mask_size) bool action masks for ``dist`` (Categorical or MultiCategorical).

    Each action is allowed with probability 1/2; every row (each action dimension of it) keeps at
    least one allowed action, as the masking contract requires.
    """
    rng = np.random.default_rng(seed)
    parts = []
    for size in getattr(dist, "nvec", None) or [dist.mask_size]:
        part = rng.random((n, size)) < 0.5
        part[np.arange(n), rng.integers(size, size=n)] |= ~part.any(-1)
        parts.append(part)
    return np.concatenate(parts, axis=1)


def env_rollout(model: Any, env: Any, steps: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray | None]:
    """Observations of ``steps`` deterministic policy steps in ``env`` (all envs), stacked, and the
    env's action masks at each of them ((n, mask_size) bool), None when the model uses no masks.
    The steps are played by :func:`rlchain.policy.play.play` (RNN state zeroed where episodes end)."""

    seen, masks = [], []

    def record(obs: torch.Tensor, mask: torch.Tensor | None) -> None:
        seen.append(obs.to("cpu"))
        if mask is not None:
            masks.append(mask.cpu())

    play(model, env, None, deterministic=True, seed=seed, steps=steps, on_obs=record)
    masks_out = torch.cat(masks).numpy() if masks else None
    if seen and isinstance(seen[0], dict):  # Dict observations kept per key
        return {k: torch.cat([s[k] for s in seen]).numpy() for k in seen[0]}, masks_out
    return torch.cat(seen).numpy(), masks_out


def env_observations(model: Any, env: Any, steps: int, seed: int = 0) -> np.ndarray:
    """Observations from ``steps`` deterministic policy steps in ``env`` (all envs), stacked."""
    return env_rollout(model, env, steps, seed)[0]
