"""The off-policy stepper: one env step of every env into a replay buffer.

It steps the envs with the actions it is given, reports the step's outcome to the run (episode statistics,
success, callbacks: :meth:`RunContext.record_step`), shapes and checks the rewards, stores each transition
with the true final observation of an ended episode (``next_obs`` of a time-out is not the next episode's
first one), folds the new observations into the model's normalizers and counts the frames. Which actions
to take and when to update stay with the algorithm (SAC, DQN; a user's off-policy algorithm).
"""

from __future__ import annotations

from typing import Any

import torch

from rlchain.algos.core.returns import shape_with
from rlchain.envs.obs_dict import ObsDict
from rlchain.envs.vecenv import VecEnv
from rlchain.errors import DivergenceError


class OffPolicyStepper:
    """Steps ``env`` for the run ``ctx`` (its RunContext) into ``buffer`` (``add(obs, actions, rewards,
    next_obs, terminated, truncated)``); ``cfg`` (the run's config) gives ``reward_shaper``. Multi-column
    rewards are summed."""

    def __init__(self, env: VecEnv, model: Any, ctx: Any, cfg: Any, buffer: Any) -> None:
        self.env, self.model, self.ctx, self.cfg, self.buffer = env, model, ctx, cfg, buffer
        self.num_envs = env.num_envs

    def step(self, obs: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """Step every env with ``actions`` (the model's format) from ``obs``; returns the next observations."""
        ctx, model = self.ctx, self.model
        rs = self.cfg.reward_shaper
        result = self.env.step(ctx.spec.to_env(model.dist.to_env(actions)))
        rewards, terminated, truncated, dones = ctx.record_step(result)
        if rewards.dim() > 1:
            rewards = rewards.sum(-1)
        shaped = shape_with(rewards, rs)
        next_obs = ctx.to_tensor(result.obs)
        if not bool(torch.isfinite(shaped).all()) or not all_finite(next_obs):
            raise DivergenceError("the env returned a non-finite reward or observation")
        real_next = next_obs
        if bool(dones.any()):
            real_next = next_obs.clone()
            rows = dones.nonzero().squeeze(-1)
            final = ctx.to_tensor(result.final_obs)[rows]
            # per key, each buffer casts on assignment; a flat tensor is cast to the observations' dtype
            real_next[rows] = final if isinstance(final, ObsDict) else final.to(next_obs.dtype)
        self.buffer.add(obs, actions, shaped, real_next, terminated, truncated)
        model.update_normalizers(obs=next_obs)
        ctx.frames += self.num_envs
        return next_obs


def all_finite(obs: torch.Tensor | ObsDict) -> bool:
    """Whether every floating-point value of ``obs`` (every key of an ObsDict) is finite."""
    parts = obs.values() if isinstance(obs, ObsDict) else (obs,)
    return all(bool(torch.isfinite(p).all()) for p in parts if p.is_floating_point())
