"""Small gymnasium Dict envs for the smoke tests of per-key observations: an (8, 8, 3) uint8 image lit on one
side and a vector; reward 1 for naming the side (a Discrete action)."""

import gymnasium as gym
import numpy as np


class ImageSide(gym.Env):
    """The image and a constant vector (``VEC``); episodes of ``EPISODE`` steps."""

    EPISODE = 20
    VEC = 0.0

    def __init__(self):
        self.observation_space = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (8, 8, 3), np.uint8),
                                                  "vec": gym.spaces.Box(-1, 1, (2,), np.float32)})
        self.action_space = gym.spaces.Discrete(2)

    def _obs(self):
        image = np.zeros((8, 8, 3), np.uint8)
        image[:, 0 if self.side == 0 else 7] = 255
        return {"image": image, "vec": np.full(2, self.VEC, np.float32)}

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        self.t, self.side = 0, int(self.np_random.integers(2))
        return self._obs(), {}

    def step(self, action):
        reward = float(int(action) == self.side)
        self.t, self.side = self.t + 1, int(self.np_random.integers(2))
        return self._obs(), reward, False, self.t >= self.EPISODE, {}


class ImageSideStep(ImageSide):
    """ImageSide with a Discrete step counter beside the image and the vector (0.5); episodes of 10 steps."""

    EPISODE = 10
    VEC = 0.5

    def __init__(self):
        super().__init__()
        self.observation_space = gym.spaces.Dict({**self.observation_space.spaces,
                                                  "step": gym.spaces.Discrete(self.EPISODE + 1)})

    def _obs(self):
        return {**super()._obs(), "step": self.t}
