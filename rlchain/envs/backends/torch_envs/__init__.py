"""Built-in batched torch envs, for :data:`rlchain.registry.ENVS` (:data:`ENV_BUILDERS`):

- ``TorchCartPole-v0``: gymnasium CartPole-v1, Discrete(2), 500-step limit;
- ``TorchPendulum-v0``: gymnasium Pendulum-v1, Box(1), 200-step limit;
- ``TorchReacher8-v0``: an 8-link planar reacher, Box(8), 200-step limit;
- ``TorchPointMass-v0``: a damped 2-D point mass to a goal, Box(2), 100-step limit, info ``success``
  (differentiable, like the pendulum: APG);
- ``TorchPush2D-v0``: a planar push-cube with EmbodiChain's push_cube starts, reward terms and success
  test (cube within 0.1 m of the goal), Box(2), 100-step limit;
- ``TorchCameraReach-v0``: a planar reach whose goal is only in a (1, 24, 24) uint8 camera image beside the
  robot's proprioception (a Dict observation kept per key), Box(2), 25-step episodes, info ``success``.

Use them as ``params.config.env_name``; ``env_config.device`` (default cpu) picks where the
batch lives and should match ``params.config.device``. Other ``env_config`` keys:
``max_episode_steps`` (all), ``g`` (pendulum), ``num_links``, ``ctrl_cost``, ``target_radius``
(reacher). See docs/tensor_envs.md.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from rlchain.envs.backends.tensor_env import TensorVecEnv
from rlchain.envs.backends.torch_envs.camera_reach import TorchCameraReach
from rlchain.envs.backends.torch_envs.cartpole import TorchCartPole
from rlchain.envs.backends.torch_envs.pendulum import TorchPendulum
from rlchain.envs.backends.torch_envs.point_mass import TorchPointMass
from rlchain.envs.backends.torch_envs.push2d import TorchPush2D
from rlchain.envs.backends.torch_envs.reacher import TorchReacher

CONFIG = "params.config.env_config"


def _builder(cls: type[TensorVecEnv], name: str, **fixed: Any) -> Callable[..., TensorVecEnv]:
    """``(num_envs, seed, device='cpu', render=False, **env_config) -> cls`` with config errors that
    name the key (a ValueError, which build_env turns into a ConfigError)."""
    accepted = [p for p in inspect.signature(cls).parameters if p not in ("num_envs", "seed", "device")]
    accepted = [p for p in accepted if p not in fixed]

    def build(num_envs: int, seed: int | None, device: str = "cpu", render: bool = False,
              **env_config: Any) -> TensorVecEnv:
        if render:
            raise ValueError(f"params.config.player.render: {name} is a tensor env and does not render; "
                             f"set render: False")
        for key in env_config:
            if key not in accepted:
                raise ValueError(f"{CONFIG}.{key}: not an option of {name} "
                                 f"(valid: device, {', '.join(accepted)})")
        return cls(num_envs, device=device, seed=seed, **fixed, **env_config)

    build.__name__ = build.__qualname__ = f"build_{name.split('-')[0].lower()}"
    build.__doc__ = f"Builder of ``{name}`` ({cls.__name__}) for the ENVS registry."
    return build


build_torch_cartpole = _builder(TorchCartPole, "TorchCartPole-v0")
build_torch_pendulum = _builder(TorchPendulum, "TorchPendulum-v0")
build_torch_reacher8 = _builder(TorchReacher, "TorchReacher8-v0", num_links=8)
build_torch_point_mass = _builder(TorchPointMass, "TorchPointMass-v0")
build_torch_push2d = _builder(TorchPush2D, "TorchPush2D-v0")
build_torch_camera_reach = _builder(TorchCameraReach, "TorchCameraReach-v0")

ENV_BUILDERS = {"TorchCartPole-v0": build_torch_cartpole, "TorchPendulum-v0": build_torch_pendulum,
                "TorchReacher8-v0": build_torch_reacher8, "TorchPointMass-v0": build_torch_point_mass,
                "TorchPush2D-v0": build_torch_push2d, "TorchCameraReach-v0": build_torch_camera_reach}
"""``env_name`` -> builder, for :data:`rlchain.registry.ENVS` (rlchain.builtins registers them)."""

__all__ = ["TensorVecEnv", "TorchCartPole", "TorchPendulum", "TorchReacher", "TorchPointMass", "TorchPush2D",
           "TorchCameraReach", "build_torch_cartpole", "build_torch_pendulum", "build_torch_reacher8",
           "build_torch_point_mass", "build_torch_push2d", "build_torch_camera_reach"]
