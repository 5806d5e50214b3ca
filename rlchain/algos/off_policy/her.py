"""Hindsight Experience Replay (Andrychowicz et al., 2017) for goal-conditioned envs.

A goal env (gymnasium-robotics style) observes a Dict ``{observation, achieved_goal, desired_goal}``
that reaches rlchain flattened (``envs/wrappers/dict_obs.py``); :func:`goal_layout` finds where the two goals
sit in the flat vector. :class:`HERReplayBuffer` stores transitions as the plain buffer does and
also where each one sits in its episode. When sampling, a fraction ``k / (k + 1)`` of the minibatch
gets a new desired goal: the goal achieved at a later step of the same episode (``future``) or at
its last step (``final``); the desired-goal part of ``obs`` and ``next_obs`` is replaced and the
reward recomputed with the env's ``compute_reward(achieved_goal, desired_goal, info)`` (see
``rlchain/envs/wrappers/goal_env.py`` for where that comes from).

Episodes are stored with a stride: every vectorized step writes ``num_envs`` consecutive slots, so
the transition of the same env ``j`` steps later is ``j * num_envs`` slots further on. The ring
overwrites the oldest slots first, so a stored transition's later steps are always still stored.
``terminated`` is kept as stored (Fetch tasks never terminate; an env that ends episodes on
success would need its terminal flags recomputed too, which this does not do).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import torch

from rlchain.algos.core.replay import ReplayBuffer

STRATEGIES = ("future", "final")
ACHIEVED, DESIRED = "achieved_goal", "desired_goal"


@dataclass(frozen=True)
class GoalLayout:
    """Where the goals sit in a flat observation: ``achieved`` and ``desired`` slices (equal length)."""

    achieved: slice
    desired: slice


def goal_layout(space: gym.Space) -> GoalLayout:
    """The goal slices of the flat observation of a Dict goal space (the env's FlatDictBox / Dict).

    Raises ValueError naming what is missing when the observations are not goal Dicts.
    """
    dict_space = space if isinstance(space, gym.spaces.Dict) else getattr(space, "dict_space", None)
    if dict_space is None:
        raise ValueError("hindsight replay needs Dict observations with achieved_goal and desired_goal "
                         f"(a goal env); this env observes {space}")
    slices, start = {}, 0
    for key, sub in dict_space.spaces.items():
        size = int(gym.spaces.flatdim(sub))
        slices[key] = slice(start, start + size)
        start += size
    missing = [k for k in (ACHIEVED, DESIRED) if k not in slices]
    if missing:
        raise ValueError(f"hindsight replay needs the observation keys achieved_goal and desired_goal; "
                         f"missing {', '.join(missing)} (keys: {', '.join(slices)})")
    a, d = slices[ACHIEVED], slices[DESIRED]
    if a.stop - a.start != d.stop - d.start:
        raise ValueError(f"achieved_goal ({a.stop - a.start} values) and desired_goal ({d.stop - d.start}) "
                         f"differ in size")
    return GoalLayout(a, d)


def relabel_probability(k: int) -> float:
    """The fraction of a minibatch that gets hindsight goals for ``k`` relabelled goals per real one."""
    return k / (k + 1.0)


def future_offsets(remaining: torch.Tensor, strategy: str, u: torch.Tensor) -> torch.Tensor:
    """Steps ahead of the goal step: ``future`` uniform in [0, remaining], ``final`` = remaining.

    ``remaining`` (B,) long: steps after each transition in its episode (so far); ``u`` (B,) in [0, 1).
    Step 0 is the transition's own next state, whose achieved goal is a valid hindsight goal.
    """
    if strategy == "final":
        return remaining.clone()
    return torch.minimum((u * (remaining + 1).double()).long(), remaining)


class HERReplayBuffer(ReplayBuffer):
    """A uniform one-step replay buffer with hindsight goals (see the module docstring).

    ``reward_fn(achieved (B, G), desired (B, G)) -> (B,)`` tensors on the buffer's device: the env's
    ``compute_reward`` followed by the run's reward shaping.
    """

    def __init__(self, capacity: int, obs_shape: tuple[int, ...], action_shape: tuple[int, ...],
                 layout: GoalLayout, reward_fn: Callable[[torch.Tensor, torch.Tensor], torch.Tensor],
                 strategy: str = "future", k: int = 4, **kwargs: Any) -> None:
        if strategy not in STRATEGIES:
            raise ValueError(f"her strategy must be one of {', '.join(STRATEGIES)}, got {strategy!r}")
        if kwargs.get("n_step", 1) != 1 or kwargs.get("prioritized", False):
            raise ValueError("hindsight replay works with n_step 1 and uniform replay only")
        super().__init__(capacity, obs_shape, action_shape, **kwargs)
        self.layout, self.reward_fn, self.strategy, self.k = layout, reward_fn, strategy, int(k)
        n, c = self.num_envs, self.capacity
        self.slot_step = torch.zeros(c, dtype=torch.long)   # vectorized step that wrote the slot
        self.slot_end = torch.full((c,), -1, dtype=torch.long)  # step of its episode's last transition, -1: open
        self.episode_start = torch.zeros(n, dtype=torch.long)  # per env: step of its open episode's first transition
        self.steps = 0  # vectorized steps written so far

    def add(self, obs: torch.Tensor, actions: torch.Tensor, rewards: torch.Tensor, next_obs: torch.Tensor,
            terminated: torch.Tensor, truncated: torch.Tensor) -> None:
        """One vectorized step (leading ``num_envs`` dimension); closes the episodes that ended."""
        pos = self.pos
        super().add(obs, actions, rewards, next_obs, terminated, truncated)
        n, step = self.num_envs, self.steps
        slots = (torch.arange(n) + pos) % self.capacity
        self.slot_step[slots] = step
        self.slot_end[slots] = -1
        ended = (terminated.reshape(-1) | truncated.reshape(-1)).cpu()
        for env in ended.nonzero().flatten().tolist():
            length = min(step - int(self.episode_start[env]) + 1, self.capacity // n)
            back = slots[env] - torch.arange(length) * n
            self.slot_end[back % self.capacity] = step
            self.episode_start[env] = step + 1
        self.steps = step + 1

    def sample(self, batch_size: int, beta: float | None = None,
               generator: torch.Generator | None = None) -> dict[str, torch.Tensor]:
        """A uniform minibatch, ``k / (k + 1)`` of it with hindsight goals and recomputed rewards;
        ``relabelled`` (B,) bool says which."""
        batch = super().sample(batch_size, beta, generator)
        idx = batch["indices"].cpu()
        relabel = torch.rand(batch_size, generator=generator) < relabel_probability(self.k)
        if not bool(relabel.any()):
            batch["relabelled"] = relabel.to(self.device)
            return batch
        rows = relabel.nonzero().flatten()
        src = idx[rows]
        last = torch.where(self.slot_end[src] >= 0, self.slot_end[src], torch.full_like(src, self.steps - 1))
        remaining = (last - self.slot_step[src]).clamp(min=0)
        offsets = future_offsets(remaining, self.strategy, torch.rand(len(rows), generator=generator,
                                                                      dtype=torch.float64))
        future = (src + offsets * self.num_envs) % self.capacity
        a, d = self.layout.achieved, self.layout.desired
        goals = self.next_obs[future.to(self.device), a]
        rows_dev = rows.to(self.device)
        obs, next_obs = batch["obs"].clone(), batch["next_obs"].clone()
        obs[rows_dev, d] = goals
        next_obs[rows_dev, d] = goals
        rewards = batch["rewards"].clone()
        rewards[rows_dev] = self.reward_fn(next_obs[rows_dev, a], goals).to(rewards.dtype).reshape(-1)
        batch.update(obs=obs, next_obs=next_obs, rewards=rewards, relabelled=relabel.to(self.device))
        return batch

    def state_dict(self) -> dict[str, Any]:
        state = super().state_dict()
        state["her"] = {"slot_step": self.slot_step.clone(), "slot_end": self.slot_end.clone(),
                        "episode_start": self.episode_start.clone(), "steps": self.steps}
        return state

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        her = state.get("her")
        if her is not None:
            self.slot_step.copy_(her["slot_step"])
            self.slot_end.copy_(her["slot_end"])
            self.episode_start.copy_(her["episode_start"])
            self.steps = int(her["steps"])
