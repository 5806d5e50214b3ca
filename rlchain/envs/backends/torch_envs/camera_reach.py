"""TorchCameraReach-v0: a planar reach whose goal is seen only through a small camera image.

A point robot moves by position deltas (action a in [-1, 1]^2 moves it ``step_size`` * a, inside the
square [-1, 1]^2). The goal is drawn uniformly in [-0.8, 0.8]^2 and appears only in the image: a
top-down grayscale camera (1, ``image_size``, ``image_size``) uint8, rendered in torch on the env's
device (no OpenGL) as soft discs, the goal at full brightness and the robot at half. Proprioception is
the robot's own state: its position and last action (4,) float32.

Episodes last ``max_episode_steps`` (25) steps and never end early; success (``info['success']``, True
at the last step only) is the robot within ``success_threshold`` (0.15) of the goal when the episode
ends. Reward per step: minus the distance to the goal. A policy that sees only the proprioception cannot
know the goal: its best is a fixed point (the centre), which succeeds about 2.8% of the time
(pi 0.15^2 / 1.6^2), the chance level a camera policy must beat.

``observation``: ``dict`` (default) gives ``{'image': uint8 (1, S, S), 'proprio': float32 (4,)}`` as an
:class:`~rlchain.envs.obs_dict.ObsDict`; ``proprio`` gives only the proprioception as a Box (4,), for
the vector-only baseline; ``state`` gives the proprioception and the goal's position as a Box (6,) (in that
order: a state teacher for distillation reads the Dict's keys ``[proprio, goal]`` concatenated the same way).
``privileged: True`` adds ``'goal'`` (2,) float32, the goal's position, to the Dict:
privileged state for an asymmetric critic (``central_value_config``) that the actor's network leaves out.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.tensor_env import TensorVecEnv
from rlchain.envs.obs_dict import ObsDict

OBSERVATIONS = ("dict", "proprio", "state")


class TorchCameraReach(TensorVecEnv):
    """N camera reach tasks; ``state`` (N, 6): robot xy, goal xy, last action."""

    info_attrs = ("success",)
    goal_range = 0.8

    def __init__(self, num_envs: int, device: str | torch.device = "cpu", seed: int | None = None,
                 max_episode_steps: int | None = 25, success_threshold: float = 0.15, step_size: float = 0.15,
                 image_size: int = 24, observation: str = "dict", privileged: bool = False) -> None:
        if observation not in OBSERVATIONS:
            raise ValueError(f"params.config.env_config.observation: expected one of {', '.join(OBSERVATIONS)}, "
                             f"got {observation!r}")
        if int(image_size) < 8:
            raise ValueError(f"params.config.env_config.image_size: expected an int >= 8, got {image_size!r}")
        if not isinstance(privileged, bool) or (privileged and observation != "dict"):
            raise ValueError(f"params.config.env_config.privileged: expected True or False (True needs observation "
                             f"dict), got {privileged!r}")
        if max_episode_steps is None:
            raise ValueError("params.config.env_config.max_episode_steps: TorchCameraReach-v0 needs a time limit "
                             "(success is judged when the episode ends)")
        super().__init__(num_envs, device, seed, max_episode_steps)
        self.success_threshold, self.step_size = float(success_threshold), float(step_size)
        self.image_size, self.observation, self.privileged = int(image_size), observation, privileged
        size = self.image_size
        proprio = gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)
        image = gym.spaces.Box(0, 255, (1, size, size), np.uint8)
        keys = {"image": image, "proprio": proprio}
        if privileged:
            keys["goal"] = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        state = gym.spaces.Box(-np.inf, np.inf, (6,), np.float32)
        self.observation_space = gym.spaces.Dict(keys) if observation == "dict" else \
            state if observation == "state" else proprio
        self.action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.state = torch.zeros(self.num_envs, 6, device=self.device)
        self.success = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        # pixel centres in world coordinates: the camera sees [-1, 1]^2, row 0 at y = +1
        centres = (torch.arange(size, device=self.device, dtype=torch.float32) + 0.5) / size * 2.0 - 1.0
        self.pixel_x = centres.view(1, 1, size)
        self.pixel_y = centres.flip(0).view(1, size, 1)
        self.pixel = 2.0 / size

    def render_image(self, state: torch.Tensor) -> torch.Tensor:
        """(K, 6) states -> (K, 1, S, S) uint8 camera images: goal disc at 255, robot disc at 128."""
        image = 255.0 * self._disc(state[:, 2:4], 1.5) + 128.0 * self._disc(state[:, 0:2], 1.0)
        return image.clamp(0, 255).to(torch.uint8).unsqueeze(1)

    def _disc(self, xy: torch.Tensor, radius_px: float) -> torch.Tensor:
        """(K, S, S) in [0, 1]: a disc of ``radius_px`` pixels at world points ``xy`` (K, 2), edges one pixel soft."""
        dx = self.pixel_x - xy[:, 0].view(-1, 1, 1)
        dy = self.pixel_y - xy[:, 1].view(-1, 1, 1)
        dist_px = torch.sqrt(dx.square() + dy.square()) / self.pixel
        return (radius_px + 0.5 - dist_px).clamp(0.0, 1.0)

    def _obs(self, state: torch.Tensor) -> torch.Tensor | ObsDict:
        proprio = torch.cat((state[:, 0:2], state[:, 4:6]), 1)
        if self.observation == "proprio":
            return proprio
        if self.observation == "state":  # privileged: the goal beside the robot's own state
            return torch.cat((proprio, state[:, 2:4]), 1)
        obs = ObsDict({"image": self.render_image(state), "proprio": proprio})
        if self.privileged:
            obs["goal"] = state[:, 2:4].clone()
        return obs

    def _reset_idx(self, env_ids: torch.Tensor) -> torch.Tensor | ObsDict:
        k = env_ids.numel()
        new = torch.cat((self.uniform((k, 2), -0.8, 0.8), self.uniform((k, 2), -self.goal_range, self.goal_range),
                         torch.zeros(k, 2, device=self.device)), 1)
        self.state = self.state.index_put((env_ids,), new)
        return self._obs(new)

    def _step_physics(self, actions: torch.Tensor) -> tuple[torch.Tensor | ObsDict, torch.Tensor, torch.Tensor]:
        a = actions.clamp(-1.0, 1.0)
        robot = (self.state[:, 0:2] + self.step_size * a).clamp(-1.0, 1.0)
        goal = self.state[:, 2:4]
        self.state = torch.cat((robot, goal, a), 1)
        distance = (robot - goal).norm(dim=-1)
        last = self.episode_steps + 1 >= self.max_episode_steps  # the base class counts this step after us
        self.success = last & (distance < self.success_threshold)
        terminated = torch.zeros(self.num_envs, dtype=torch.bool, device=self.device)
        return self._obs(self.state), -distance, terminated
