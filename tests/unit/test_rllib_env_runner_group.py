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
        assert algo.env_runner.num_envs == 2 and algo.env_runner.config is algo.config
        assert algo.env_runner_group.foreach_env_runner(lambda r: r.num_envs) == [2]
        tasks = algo.env_runner_group.foreach_env(lambda env: env.unwrapped.task)
        with pytest.raises(FaceNotOffered, match="builds a run's envs once"):
            algo.env_runner.make_env()
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
