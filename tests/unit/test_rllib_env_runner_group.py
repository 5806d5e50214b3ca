"""``algo.env_runner_group`` / ``algo.env_runner`` and the episode callbacks' ``env_runner``, ``env``,
``rl_module`` arguments: the migration guide's callback signature (all keyword-only, no defaults) and a curriculum
that changes the envs between ``train()`` calls through ``foreach_env_runner``."""

import gymnasium as gym
import pytest

from rlchain.rllib.__main__ import explain
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.callbacks.callbacks import RLlibCallback
from rlchain.rllib.face_error import FaceNotOffered


class TaskEnv(gym.Env):
    """CartPole whose infos carry the task a curriculum set."""

    def __init__(self, config=None):
        self.inner = gym.make("CartPole-v1")
        self.observation_space, self.action_space = self.inner.observation_space, self.inner.action_space
        self.task = 0

    def set_task(self, task):
        self.task = task

    def reset(self, *, seed=None, options=None):
        return self.inner.reset(seed=seed)

    def step(self, action):
        obs, reward, term, trunc, _ = self.inner.step(action)
        return obs, reward, term, trunc, {"task": self.task}


class Curriculum(RLlibCallback):
    seen: list = []  # class-level: the config copies what it is given

    def on_episode_start(self, *, episode, env_runner, metrics_logger, env, env_index, rl_module, worker=None,
                         base_env=None, policies=None, **kwargs):
        out = rl_module.forward_inference({"obs": env.single_observation_space.sample()[None]})
        Curriculum.seen.append((env_runner.worker_index, env.num_envs, env_index, "action_dist_inputs" in out))

    def on_episode_end(self, *, episode, env_runner, metrics_logger, env, env_index, rl_module, **kwargs):
        metrics_logger.log_value("task", env.envs[env_index].unwrapped.task, reduce="max")

    def on_train_result(self, *, algorithm, result, **kwargs):
        algorithm.env_runner_group.foreach_env_runner(
            lambda runner: [e.unwrapped.set_task(algorithm.training_iteration) for e in runner.env.envs])


def test_callbacks_get_the_runner_env_and_module_and_a_curriculum_reaches_the_envs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment(TaskEnv).env_runners(num_env_runners=0, num_envs_per_env_runner=2)
            .debugging(seed=0).callbacks(Curriculum)
            .training(train_batch_size=128, minibatch_size=128, num_epochs=1).build_algo())
    try:
        first = algo.train()
        second = algo.train()
        assert algo.env_runner is algo.env_runner_group.local_env_runner
        assert algo.env_runner.num_envs == 2 and algo.env_runner.config.to_dict() == algo.config.to_dict()
        assert algo.env_runner_group.foreach_env_runner(lambda r: r.num_envs) == [2]
        tasks = algo.env_runner_group.foreach_env(lambda env: env.unwrapped.task)
    finally:
        algo.stop()
    assert Curriculum.seen and all(w == 0 and n == 2 and 0 <= i < 2 and ok for w, n, i, ok in Curriculum.seen)
    assert first["env_runners"]["task"] == 0 and second["env_runners"]["task"] == 1
    assert tasks == [[2, 2]]


def test_what_the_group_does_not_offer_is_one_line():
    from rlchain.rllib.env_runner_group import EnvRunnerGroup
    group = EnvRunnerGroup.__new__(EnvRunnerGroup)
    with pytest.raises(FaceNotOffered, match="foreach_env_runner") as info:
        group.foreach_worker(lambda w: w)
    assert explain(info.value).count("\n") == 0 and "foreach_env_runner" in explain(info.value)


class LengthEnv(gym.Env):
    """Episodes of ``env_config["length"]`` steps, reward 1 each (a curriculum's task is its length)."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,))
    action_space = gym.spaces.Discrete(2)

    def __init__(self, config):
        self.length, self.t = int(config["length"]), 0
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (int(config.get("obs", 1)),))

    def reset(self, *, seed=None, options=None):
        self.t = 0
        return self.observation_space.low * 0, {}

    def step(self, action):
        self.t += 1
        return self.observation_space.low * 0, 1.0, self.t >= self.length, False, {}


def _next_task(env_runner, length):
    env_runner.config.environment(env_config={"length": length})  # RLlib 2.60's curriculum example's pattern
    env_runner.make_env()


def test_make_env_rebuilds_the_envs_with_the_runners_new_env_config(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment(LengthEnv, env_config={"length": 2})
            .env_runners(num_env_runners=0, num_envs_per_env_runner=2).debugging(seed=0)
            .training(train_batch_size=40, minibatch_size=20, num_epochs=1).build_algo())
    try:
        assert algo.train()["env_runners"]["episode_len_mean"] == 2
        algo.env_runner_group.foreach_env_runner(lambda runner: _next_task(runner, 5))
        assert algo.config.get("env_config") == {"length": 2}  # the algorithm's config stays frozen and as built
        assert [e.unwrapped.length for e in algo.env_runner.env.envs] == [5, 5]
        result = algo.train()  # 20 steps of each env: episodes of 5 from the first step (none left of length 2)
        assert result["env_runners"]["episode_len_mean"] == 5 and result["env_runners"]["num_episodes"] == 8
        with pytest.raises(Exception, match="has other spaces than the run's") as info:
            algo.env_runner.config.environment(env_config={"length": 3, "obs": 2})
            algo.env_runner.make_env()
        assert "\n" not in str(info.value)
        assert [e.unwrapped.length for e in algo.env_runner.env.envs] == [5, 5]  # left as they were
    finally:
        algo.stop()


class EpisodeTasks(RLlibCallback):
    ended: list = []  # class-level: the config copies what it is given

    def on_episode_start(self, *, episode, env, env_index, **kwargs):
        episode.custom_data["length"] = env.envs[env_index].unwrapped.length

    def on_episode_end(self, *, episode, **kwargs):
        EpisodeTasks.ended.append((episode.custom_data["length"], episode.get_length()))


def test_after_make_env_the_episode_callbacks_get_fresh_episodes(tmp_path, monkeypatch):
    # RLlib's runner drops the episodes in progress at make_env and starts new ones (on_episode_start) at the next
    # sample: no episode a callback holds carries the old task's steps into the new one
    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment(LengthEnv, env_config={"length": 3})
            .env_runners(num_env_runners=0, num_envs_per_env_runner=2).debugging(seed=0).callbacks(EpisodeTasks)
            .training(train_batch_size=40, minibatch_size=20, num_epochs=1).build_algo())
    try:
        algo.train()  # 20 steps of each env: 6 episodes of 3 each, the 7th 2 steps in
        assert EpisodeTasks.ended == [(3, 3)] * 12
        EpisodeTasks.ended.clear()
        algo.env_runner_group.foreach_env_runner(lambda runner: _next_task(runner, 5))
        algo.train()
    finally:
        algo.stop()
    assert EpisodeTasks.ended == [(5, 5)] * 8
