"""Envs the Ray env worker tests ship to their workers (tests/smoke/test_ray_env.py). A worker imports the module
of an env class it is sent by reference: this one imports gymnasium only, so the worker stays without torch and
rlchain's algorithms as it would for gymnasium's own envs (the test module imports both)."""

import os
import time

import gymnasium as gym


class SleepyCartPole(gym.Wrapper):
    """CartPole whose step hangs for a minute the first time a flag file appears (one env takes it)."""

    def __init__(self, flag, **kw):
        super().__init__(gym.make("CartPole-v1", **kw))
        self.flag = flag

    def step(self, action):
        try:
            os.remove(self.flag)
        except FileNotFoundError:
            return self.env.step(action)
        time.sleep(60)
        return self.env.step(action)
