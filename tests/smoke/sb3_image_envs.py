"""A small channel-last image env for the SB3 CnnPolicy smoke tests: a (36, 36, 3) uint8 image (NatureCNN's
smallest) lit on one side; reward 1 for naming the side. ``dict_obs``: the image beside a vector and a Discrete
step counter; ``continuous``: a Box action whose sign names the side."""

import gymnasium as gym
import numpy as np


class SideImage(gym.Env):
    EPISODE = 10

    def __init__(self, dict_obs=False, continuous=False):
        image = gym.spaces.Box(0, 255, (36, 36, 3), np.uint8)
        self.dict_obs = dict_obs
        self.observation_space = gym.spaces.Dict({
            "img": image, "vec": gym.spaces.Box(-1, 1, (2,), np.float32),
            "step": gym.spaces.Discrete(self.EPISODE + 1)}) if dict_obs else image
        self.action_space = gym.spaces.Box(-1, 1, (1,), np.float32) if continuous else gym.spaces.Discrete(2)

    def _obs(self):
        image = np.zeros((36, 36, 3), np.uint8)
        image[:, 0 if self.side == 0 else 35] = 255
        return {"img": image, "vec": np.zeros(2, np.float32), "step": self.t} if self.dict_obs else image

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        self.t, self.side = 0, int(self.np_random.integers(2))
        return self._obs(), {}

    def step(self, action):
        named = int(action) if np.ndim(action) == 0 else int(action[0] > 0)
        reward = float(named == self.side)
        self.t, self.side = self.t + 1, int(self.np_random.integers(2))
        return self._obs(), reward, False, self.t >= self.EPISODE, {}
