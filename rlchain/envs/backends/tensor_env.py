"""Batched torch environments: the whole batch is a few tensors, stepped by vectorized math.

:class:`TensorVecEnv` implements the :mod:`rlchain.envs.vecenv` contract for tensor envs
(``is_tensor_env = True``): ``step`` takes an action tensor (N, *action_space.shape) and returns
every :class:`StepResult` field as a tensor on ``device``. A subclass only writes the physics:

- ``_reset_idx(env_ids) -> obs``: draw fresh initial states for the rows ``env_ids`` (a 1-D
  int64 tensor on ``device``) using ``self.generator``, store them, return their observations
  (len(env_ids), *obs_shape) float32;
- ``_step_physics(actions) -> (obs, reward, terminated)``: advance every row one step and return
  the new observations (N, *obs_shape) float32, rewards (N,) float32, terminated (N,) bool.

The base class counts steps per env and sets ``truncated = steps >= max_episode_steps`` (like
gymnasium's TimeLimit: a time-out can coincide with a termination, and then both are True),
auto-resets finished rows in the same call (``final_obs`` holds their last observation, ``obs``
the first one of the next episode), and seeds a :class:`torch.Generator` on ``device``. There is
no Python loop over envs: one ``_reset_idx`` call resets every finished row at once. See
docs/tensor_envs.md.
"""

from __future__ import annotations

import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.vecenv import StepResult


def resolve_env_device(device: str | torch.device) -> torch.device:
    """``cpu`` / ``cuda`` / ``cuda:N``; a cuda device without CUDA falls back to cpu with a warning
    (as ``params.config.device`` does), so one yaml runs on both kinds of machine."""
    name = str(device)
    if name.startswith("cuda") and not torch.cuda.is_available():
        warnings.warn(f"env_config.device is '{name}' but CUDA is not available; the env runs on cpu",
                      stacklevel=3)
        return torch.device("cpu")
    try:
        device = torch.device(name)
    except RuntimeError:
        raise ValueError(f"params.config.env_config.device: '{name}' is not a device (cpu, cuda, cuda:N)") from None
    if device.type == "cuda" and device.index is None:  # 'cuda' -> 'cuda:N', as tensors report it
        device = torch.device("cuda", torch.cuda.current_device())
    return device


class TensorVecEnv:
    """Base class of batched torch envs: step counter, time limit, same-step auto-reset, seeding.

    Subclasses set ``observation_space`` / ``action_space`` (single-env gymnasium spaces) before
    calling ``super().__init__`` or right after, and implement :meth:`_reset_idx` and
    :meth:`_step_physics` with tensor ops over the whole batch.
    """

    is_tensor_env = True
    steps_on_torch_threads = True  # the rollout's thread plan: see rlchain.parallel.threads.for_env
    observation_space: gym.spaces.Box
    action_space: gym.Space

    def __init__(self, num_envs: int, device: str | torch.device = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = None) -> None:
        if int(num_envs) < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        if max_episode_steps is not None and int(max_episode_steps) < 1:
            raise ValueError(f"params.config.env_config.max_episode_steps must be >= 1, got {max_episode_steps}")
        self.num_envs = int(num_envs)
        self.device = resolve_env_device(device)
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.generator = torch.Generator(device=self.device)
        if seed is None:
            self.generator.seed()
        else:
            self.generator.manual_seed(int(seed))
        self.episode_steps = torch.zeros(self.num_envs, dtype=torch.int32, device=self.device)
        self.all_ids = torch.arange(self.num_envs, device=self.device)
        self._needs_reset = True

    # ----- what subclasses implement ------------------------------------------------------------
    def _reset_idx(self, env_ids: torch.Tensor) -> torch.Tensor:
        """Draw initial states for rows ``env_ids`` (int64, on device); return their obs (K, *obs)."""
        raise NotImplementedError

    def _step_physics(self, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Advance all rows one step: (obs (N, *obs) float32, reward (N,) float32, terminated (N,) bool)."""
        raise NotImplementedError

    # ----- the VecEnv contract --------------------------------------------------------------------
    def reset(self, seed: int | None = None) -> torch.Tensor:
        """Reset every env; ``seed`` reseeds the env's generator (None: continue its stream).

        Returns obs (N, *observation_space.shape) float32 on ``device``.
        """
        if seed is not None:
            self.generator.manual_seed(int(seed))
        self.episode_steps.zero_()
        self._needs_reset = False
        return self._reset_idx(self.all_ids)

    def step(self, actions: Any) -> StepResult:
        """One step of every env with actions (N, *action_space.shape); finished envs are reset in
        the same call (``final_obs`` keeps their last observation)."""
        if self._needs_reset:
            raise RuntimeError(f"{type(self).__name__}: call reset() before step()")
        actions = self._prepare_actions(actions)
        obs, reward, terminated = self._step_physics(actions)
        self.episode_steps += 1
        if self.max_episode_steps is not None:
            truncated = self.episode_steps >= self.max_episode_steps
        else:
            truncated = torch.zeros_like(terminated)
        done = terminated | truncated
        final_obs = obs
        # one host sync per step (as in Isaac Lab); the trainer syncs on done flags anyway
        if bool(done.any()):
            env_ids = done.nonzero().squeeze(-1)
            obs = obs.clone()
            obs[env_ids] = self._reset_idx(env_ids)
            self.episode_steps[env_ids] = 0
        infos = {k: getattr(self, k) for k in self.info_attrs}
        return StepResult(obs, reward, terminated, truncated, final_obs, infos)

    def get_state(self) -> dict[str, Any]:
        """The batch's state for exact resume: every tensor attribute (a subclass's physics state, the
        step counters), the generator's state and whether a reset is due. A subclass keeping state
        outside tensors lists those attributes in ``state_attrs``."""
        tensors = {k: v.detach().clone() for k, v in vars(self).items() if isinstance(v, torch.Tensor)}
        extra = {k: getattr(self, k) for k in self.state_attrs}
        return {"tensors": tensors, "extra": extra, "generator": self.generator.get_state(),
                "needs_reset": self._needs_reset}

    def set_state(self, state: dict[str, Any]) -> None:
        """Put back :meth:`get_state`'s result (tensors move to this env's device)."""
        for key, value in state["tensors"].items():
            setattr(self, key, value.to(self.device).clone())
        for key, value in state["extra"].items():
            setattr(self, key, value)
        self.generator.set_state(state["generator"].cpu())
        self._needs_reset = bool(state["needs_reset"])

    state_attrs: tuple[str, ...] = ()
    """Non-tensor attributes that change while stepping (saved by :meth:`get_state`)."""

    info_attrs: tuple[str, ...] = ()
    """Attributes every step's info holds under their names (e.g. ``("success",)``: a subclass's flag)."""

    def has_action_mask(self) -> bool:
        """Whether :meth:`get_action_mask` is implemented: a subclass with masks overrides both."""
        return False

    def get_action_mask(self) -> torch.Tensor:
        """(N, mask_size) bool masks of valid actions in the current states, on ``device``."""
        raise NotImplementedError(f"{type(self).__name__} has no action masks")

    def close(self) -> None:
        """Nothing to release: the batch is a few tensors."""

    def seed(self, seed: int) -> None:
        """Reseed the env's generator (the next reset uses it)."""
        self.generator.manual_seed(int(seed))

    # ----- helpers --------------------------------------------------------------------------------
    def _prepare_actions(self, actions: Any) -> torch.Tensor:
        """Actions as a tensor on ``device``: int64 (N,) for Discrete, int64 (N, K) for MultiDiscrete /
        MultiBinary / Tuple of Discrete, float32 (N, *shape) for Box."""
        if not isinstance(actions, torch.Tensor):
            actions = torch.as_tensor(np.asarray(actions))
        if actions.device != self.device:
            actions = actions.to(self.device)
        space = self.action_space
        if isinstance(space, gym.spaces.Discrete):
            if actions.dim() == 2 and actions.shape[1] == 1:
                actions = actions.squeeze(1)
            expected: tuple[int, ...] = (self.num_envs,)
            if actions.dtype != torch.int64:
                actions = actions.long()
        elif isinstance(space, (gym.spaces.MultiDiscrete, gym.spaces.MultiBinary, gym.spaces.Tuple)):
            width = len(space.spaces) if isinstance(space, gym.spaces.Tuple) else None
            expected = (self.num_envs, width) if width is not None else (self.num_envs, *space.shape)
            if actions.dtype != torch.int64:
                actions = actions.long()
        else:
            expected = (self.num_envs, *space.shape)
            if actions.dtype != torch.float32:
                actions = actions.float()
        if tuple(actions.shape) != expected:
            raise ValueError(f"{type(self).__name__}.step: actions have shape {tuple(actions.shape)}, "
                             f"expected {expected} (num_envs x action_space.shape)")
        return actions

    def uniform(self, shape: tuple[int, ...], low: Any, high: Any) -> torch.Tensor:
        """U(low, high) samples of ``shape`` from the env's generator (float32, on device)."""
        u = torch.rand(shape, generator=self.generator, device=self.device)
        return low + (high - low) * u

    def __repr__(self) -> str:
        return f"{type(self).__name__}(num_envs={self.num_envs}, device={self.device})"
