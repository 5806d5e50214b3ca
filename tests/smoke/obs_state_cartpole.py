"""CartPole whose actor sees position and angle and whose critic sees the full state, and the central value
config the runs on it use: the smoke tests of the central value, and benchmarks/studies/same_seed_checkpoint.py,
which loads this file by path into another tree's process (so it imports only gymnasium and numpy).

Importing it registers :data:`ENV_ID` with gymnasium (``params.import_modules`` may name it)."""

import gymnasium as gym
import numpy as np

ENV_ID = "ObsStateCartPoleTest-v0"


def central_value_config(*extra: str) -> str:
    """``params.config.central_value_config``: a 32-unit critic on the state, with the ``key: value`` entries
    ``extra`` added."""
    return "{" + ", ".join(["network: {name: actor_critic, central_value: True, mlp: {units: [32]}}",
                            "learning_rate: 1e-3", "mini_epochs: 2", *extra]) + "}"


class ObsStateCartPole(gym.Wrapper):
    """CartPole whose actor sees position and angle, and whose critic sees the full state."""

    def __init__(self, env):
        super().__init__(env)
        box = env.observation_space
        self.observation_space = gym.spaces.Dict({
            "obs": gym.spaces.Box(box.low[[0, 2]], box.high[[0, 2]], dtype=np.float32), "state": box})

    def _split(self, obs):
        return {"obs": obs[[0, 2]].astype(np.float32), "state": obs.astype(np.float32)}

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        return self._split(obs), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._split(obs), reward, terminated, truncated, info


if ENV_ID not in gym.registry:
    gym.register(ENV_ID, entry_point=lambda **kw: ObsStateCartPole(gym.make("CartPole-v1", **kw)))
