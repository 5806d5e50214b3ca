"""Stand-ins of the shape of EmbodiChain's push_cube and cart_pole tasks, written to EmbodiChain's env
contract (rlchain.envs.backends.embodichain_env): nested dict observations, ``info`` with ``success``,
``fail``, ``elapsed_steps``, ``metrics`` and unweighted ``rewards`` terms. EmbodiChain's own tasks need
its DexSim simulator, which does not install here; point ``trainer.gym_config`` at one of these names to
run its configs as written:

- ``EmbodiChainPushStandIn``: a planar push-cube (rlchain's TorchPush2D-v0: a gripper pushes a cube to a goal,
  EmbodiChain's push_cube starts, reward terms and success test), continuous 2-D action;
- ``EmbodiChainCartPoleStandIn``: cart-pole with a continuous force in [-1, 1] (x force_mag), the pole
  kept up for ``max_episode_steps`` steps counts as success.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.embodichain_env import contract_builder
from rlchain.envs.backends.torch_envs.cartpole import TorchCartPole
from rlchain.envs.backends.torch_envs.push2d import TorchPush2D


class ContinuousCartPole(TorchCartPole):
    """TorchCartPole with a Box(1) action: the force is clip(a, -1, 1) * force_mag."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def _force(self, actions: torch.Tensor) -> torch.Tensor:
        return actions[:, 0].clamp(-1.0, 1.0) * self.force_mag


class _Contract:
    """An rlchain tensor env seen through EmbodiChain's contract; subclasses say how obs and terms look."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.num_envs, self.device = inner.num_envs, inner.device
        self.single_action_space = inner.action_space

    def _obs(self, flat: torch.Tensor) -> dict:
        raise NotImplementedError

    def _terms(self, obs: torch.Tensor, reward: torch.Tensor, success: torch.Tensor) -> tuple[dict, dict]:
        raise NotImplementedError

    def reset(self, seed: int | None = None, options: Any = None) -> tuple[dict, dict]:
        return self._obs(self.inner.reset(seed)), {}

    def step(self, action: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        elapsed = self.inner.episode_steps + 1
        r = self.inner.step(action)
        success = self._success(r)
        rewards, metrics = self._terms(r.final_obs, r.reward, success)
        info = {"success": success, "fail": r.terminated & ~success, "elapsed_steps": elapsed,
                "rewards": rewards, "metrics": metrics}
        return self._obs(r.obs), r.reward, r.terminated, r.truncated, info

    def get_state(self) -> Any:
        return self.inner.get_state()

    def set_state(self, state: Any) -> None:
        self.inner.set_state(state)

    def close(self) -> None:
        self.inner.close()


class PushStandIn(_Contract):
    """Planar push-cube stand-in: obs {'robot': {'ee_pos': (N, 2)}, 'object': {'cube_pos', 'goal_pos', ...}}."""

    def __init__(self, num_envs: int, device: Any = "cpu", max_episode_steps: int = 100,
                 success_threshold: float = 0.1) -> None:
        super().__init__(TorchPush2D(num_envs, device, None, max_episode_steps, success_threshold))

    def _obs(self, flat: torch.Tensor) -> dict:
        return {"robot": {"ee_pos": flat[:, 0:2], "last_action": flat[:, 10:12]},
                "object": {"cube_pos": flat[:, 2:4], "goal_pos": flat[:, 4:6], "cube_to_goal": flat[:, 6:8],
                           "ee_to_cube": flat[:, 8:10]}}

    def _success(self, r: Any) -> torch.Tensor:
        return r.infos["success"]

    def _terms(self, obs: torch.Tensor, reward: torch.Tensor, success: torch.Tensor) -> tuple[dict, dict]:
        return dict(self.inner.last_terms), {"distance_to_goal": obs[:, 6:8].norm(dim=-1)}


class CartPoleStandIn(_Contract):
    """Continuous cart-pole stand-in: obs {'robot': {'qpos': (N, 2), 'qvel': (N, 2)}} (cart x, pole angle)."""

    def __init__(self, num_envs: int, device: Any = "cpu", max_episode_steps: int = 200) -> None:
        super().__init__(ContinuousCartPole(num_envs, device, None, max_episode_steps))

    def _obs(self, flat: torch.Tensor) -> dict:
        return {"robot": {"qpos": flat[:, [0, 2]], "qvel": flat[:, [1, 3]]}}

    def _success(self, r: Any) -> torch.Tensor:
        return r.truncated & ~r.terminated

    def _terms(self, obs: torch.Tensor, reward: torch.Tensor, success: torch.Tensor) -> tuple[dict, dict]:
        return {"alive": reward}, {"pole_angle": obs[:, 2].abs(), "cart_position": obs[:, 0].abs()}


ENV_BUILDERS = {"EmbodiChainPushStandIn": contract_builder("EmbodiChainPushStandIn", PushStandIn),
                "EmbodiChainCartPoleStandIn": contract_builder("EmbodiChainCartPoleStandIn", CartPoleStandIn)}
"""``env_name`` -> builder, for :data:`rlchain.registry.ENVS` (rlchain.builtins registers them)."""
