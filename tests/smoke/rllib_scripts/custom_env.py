"""RLlib's custom-env and callbacks pages: an env class built with env_config (EnvContext), a register_env name,
an RLlibCallback logging custom metrics."""
import gymnasium as gym
import numpy as np
from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.callbacks.callbacks import RLlibCallback
from ray.tune.registry import register_env

SEEN = []


class Corridor(gym.Env):
    def __init__(self, config):
        self.end = config["corridor_length"]
        SEEN.append((config.worker_index, config.vector_index))
        self.observation_space = gym.spaces.Box(0.0, self.end, (1,), np.float32)
        self.action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        self.pos = 0
        return np.array([self.pos], np.float32), {}

    def step(self, action):
        self.pos = max(0, self.pos + (1 if action == 1 else -1))
        done = self.pos >= self.end
        return np.array([self.pos], np.float32), 1.0 if done else -0.1, done, False, {}


class Metrics(RLlibCallback):
    def __init__(self):
        self.results = 0
        self.episodes = 0

    def on_algorithm_init(self, *, algorithm, metrics_logger=None, **kwargs):
        metrics_logger.log_value("inits", 1)

    def on_episode_end(self, *, episode, metrics_logger=None, **kwargs):
        self.episodes += 1
        metrics_logger.log_value("corridor_len", episode.get_length())

    def on_train_result(self, *, algorithm, metrics_logger=None, result, **kwargs):
        self.results += 1
        result["my_results"] = self.results


config = (PPOConfig().environment(Corridor, env_config={"corridor_length": 5})
          .env_runners(num_env_runners=2, num_envs_per_env_runner=2)
          .training(train_batch_size=200, minibatch_size=50, num_epochs=2)
          .callbacks(Metrics))
algo = config.build_algo()
result = algo.train()
assert sorted(set(SEEN[-4:])) == [(1, 0), (1, 1), (2, 0), (2, 1)], SEEN
assert result["my_results"] == 1 and result["inits"] == 1
assert result["env_runners"]["corridor_len"] > 0, result["env_runners"]
algo.stop()

register_env("corridor", lambda cfg: Corridor(cfg))
algo = PPOConfig().environment("corridor", env_config={"corridor_length": 3}).training(
    train_batch_size=128, minibatch_size=64, num_epochs=1).build()
assert algo.train()["num_env_steps_sampled_lifetime"] == 128
algo.stop()
print("OK")
