"""``config.evaluation(custom_evaluation_function=fn)``: ``algo.evaluate()`` calls ``fn(algo,
algo.eval_env_runner_group)`` as RLlib 2.60 does; the function reaches each evaluation runner's envs, samples
episodes, merges the runners' metrics into ``algo.metrics`` and the evaluation results are what it logged."""

import gymnasium as gym
import numpy as np
import pytest

from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.utils.metrics import ENV_RUNNER_RESULTS, EVALUATION_RESULTS


class Fixed(gym.Env):
    """Ends after ``length`` steps whatever the actions, reward 1 a step (so a return is the length)."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, config):
        self.length, self.t = int(config.get("length", 2)), 0

    def set_length(self, length):
        self.length = length

    def reset(self, *, seed=None, options=None):
        self.t = 0
        return np.zeros(1, np.float32), {}

    def step(self, action):
        self.t += 1
        return np.zeros(1, np.float32), 1.0, self.t >= self.length, False, {}


def evaluate_by_runner(algorithm, eval_workers):
    eval_workers.foreach_env_runner(
        lambda runner: [env.unwrapped.set_length(2 + 2 * runner.worker_index) for env in runner.env.unwrapped.envs],
        local_env_runner=False)
    out = eval_workers.foreach_env_runner(lambda runner: (runner.sample(num_episodes=2), runner.get_metrics()),
                                          local_env_runner=False)
    algorithm.metrics.aggregate([metrics for _, metrics in out], key=(EVALUATION_RESULTS, ENV_RUNNER_RESULTS))
    episodes = [e for played, _ in out for e in played]
    return (algorithm.metrics.peek((EVALUATION_RESULTS, ENV_RUNNER_RESULTS)), sum(e.env_steps() for e in episodes),
            sum(e.agent_steps() for e in episodes))


def _config(fn):
    return (PPOConfig().environment(Fixed, env_config={"length": 2})
            .training(train_batch_size=32, minibatch_size=16, num_epochs=1)
            .evaluation(custom_evaluation_function=fn, evaluation_num_env_runners=2, evaluation_interval=1))


def test_a_custom_evaluation_function_runs_on_the_evaluation_runners(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = _config(evaluate_by_runner).build_algo()
    try:
        assert algo.eval_env_runner_group.healthy_env_runner_ids() == [1, 2]
        result = algo.train()["evaluation"][ENV_RUNNER_RESULTS]
        # runner 1 plays two episodes of 4 steps, runner 2 two of 6: the means weighted by episodes
        assert result["episode_return_mean"] == 5.0 and result["episode_len_mean"] == 5.0
        assert (result["episode_return_min"], result["episode_return_max"]) == (4.0, 6.0)
        assert (result["num_episodes"], result["num_env_steps_sampled"]) == (4, 20)
        assert algo.evaluate()[ENV_RUNNER_RESULTS]["num_episodes"] == 4
    finally:
        algo.stop()


def test_a_custom_evaluation_functions_wrong_return_is_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = _config(lambda algorithm, workers: {"x": 1}).build_algo()
    try:
        with pytest.raises(ValueError, match="expected \\(results dict, env_steps, agent_steps\\), got dict"):
            algo.evaluate()
    finally:
        algo.stop()


def test_the_local_runner_beside_remote_ones_has_no_env_as_in_rllib(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = _config(evaluate_by_runner).build_algo()
    try:
        local = algo.eval_env_runner_group.local_env_runner
        assert local.env is None
        with pytest.raises(RuntimeError, match="local_env_runner=False"):
            local.sample(num_episodes=1)
    finally:
        algo.stop()


def test_sample_without_a_count_plays_a_rollout_fragment_on_the_local_runner_alone(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = _config(evaluate_by_runner).evaluation(evaluation_num_env_runners=0).env_runners(
        num_envs_per_env_runner=3, rollout_fragment_length=4)
    algo = config.build_algo()
    try:
        group = algo.eval_env_runner_group
        [played] = group.foreach_env_runner(lambda runner: runner.sample())  # 4 steps of each env: 2 episodes
        assert [e.get_length() for e in played] == [2] * 6 and group.num_remote_env_runners() == 0
        group.local_env_runner.get_metrics()
        assert group.foreach_env_runner(lambda runner: runner.sample(num_timesteps=3)) == [[]]  # 1 step of each
        [part] = group.foreach_env_runner(lambda runner: runner.sample(num_timesteps=5))  # 2 steps of each
        assert [e.get_length() for e in part] == [2, 2, 2]
        metrics = group.local_env_runner.get_metrics()
        assert (metrics["num_episodes"], metrics["num_env_steps_sampled"]) == (3, 9)
    finally:
        algo.stop()
