"""RLlib 2.60's evaluation checks at build time (rlchain/rllib/evaluation_settings.py): each refusal one line."""

import numpy as np
import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.ppo import PPOConfig


def _config(**evaluation):
    return PPOConfig().environment("CartPole-v1").evaluation(**evaluation)


def test_parallel_evaluation_needs_evaluation_env_runners():
    config = _config(evaluation_parallel_to_training=True, evaluation_interval=1)
    with pytest.raises(ConfigError, match="evaluation_parallel_to_training: True needs evaluation_num_env_runners "
                                          "> 0") as err:
        config.build_algo()  # refused before any env is built, as RLlib's validate() in build_algo
    assert "\n" not in str(err.value)
    assert isinstance(err.value, ValueError)  # RLlib's is a ValueError
    _config(evaluation_parallel_to_training=True, evaluation_num_env_runners=1).validate()
    _config(evaluation_parallel_to_training=False).validate()


def test_auto_duration_needs_parallel_evaluation():
    with pytest.raises(ConfigError, match="evaluation_duration: 'auto' needs evaluation_parallel_to_training=True"):
        _config(evaluation_duration="auto").validate()
    _config(evaluation_duration="auto", evaluation_parallel_to_training=True, evaluation_num_env_runners=1).validate()


@pytest.mark.parametrize("duration", [0, -3, 2.5, "10", True])
def test_duration_is_a_whole_number(duration):
    with pytest.raises(ConfigError, match="evaluation_duration: expected a whole number > 0 or 'auto'"):
        _config(evaluation_duration=duration).validate()


def test_old_evaluation_worker_name_counts():
    _config(evaluation_parallel_to_training=True, evaluation_num_workers=2).validate()


def _params(env_name):
    from rlchain.config import parse_params
    return parse_params({"params": {
        "algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "separate": False, "space": {"discrete": None},
                    "mlp": {"units": [8], "activation": "tanh"}},
        "config": {"env_name": env_name, "num_actors": 1, "horizon_length": 4, "minibatch_size": 4}}})


def test_evaluation_config_env_is_the_env_evaluate_plays():
    # RLlib's cartpole_truncated_ppo.py trains on a 50-step CartPole and evaluates on the 500-step CartPole-v1
    from rlchain.envs.factory import build_env
    from rlchain.rllib.evaluation_env import evaluation_params
    params = _params("CartPole-v1")
    settings = PPOConfig.overrides(env="CartPole-v1", env_config={"max_episode_steps": 3})
    out = evaluation_params({"env": "Other-v0", "evaluation_config": settings}, params)
    assert out.config.env_name != "CartPole-v1" and params.config.env_name == "CartPole-v1"
    env = build_env(out, 1, 0)
    try:
        env.reset()
        steps = 0
        while True:  # the override's env_config reached gym.make: the episode is cut at 3 steps (about 20 without)
            steps += 1
            step = env.step(np.array([steps % 2]))
            if bool(step.terminated[0]) or bool(step.truncated[0]):
                break
        assert steps == 3
    finally:
        env.close()


def test_no_evaluation_env_override_keeps_the_runs_params():
    from rlchain.rllib.evaluation_env import evaluation_params
    params = _params("CartPole-v1")
    assert evaluation_params({"evaluation_config": {"explore": False}}, params) is params
    assert evaluation_params({"evaluation_config": None}, params) is params


def test_evaluation_env_config_is_merged_into_the_configs_as_rllib_deep_updates_it():
    from rlchain.rllib.evaluation_env import evaluation_env_config
    settings = {"env_config": {"size": 4, "nested": {"x": 1, "y": 1}},
                "evaluation_config": {"env_config": {"slippery": False, "nested": {"y": 2}}}}
    assert evaluation_env_config(settings) == {"size": 4, "slippery": False, "nested": {"x": 1, "y": 2}}
    assert settings["env_config"] == {"size": 4, "nested": {"x": 1, "y": 1}}  # the training env's is untouched
    assert evaluation_env_config({"env_config": {"a": 1}, "evaluation_config": {"explore": False}}) == {"a": 1}


@pytest.mark.parametrize("settings, explore", [
    ({}, True),  # RLlib's evaluation runners explore unless told otherwise (the config's explore, True)
    ({"explore": False}, False),
    ({"evaluation_config": {"explore": False}}, False),
    ({"explore": False, "evaluation_config": {"explore": True}}, True),
    ({"explore": False, "evaluation_config": {"env_config": {}}}, False),
])
def test_evaluation_samples_unless_explore_is_false_as_in_rllib(settings, explore):
    from rlchain.rllib.evaluation_env import evaluation_explore
    assert evaluation_explore(settings) is explore


def test_evaluate_plays_what_evaluation_explore_says(tmp_path, monkeypatch):
    import rlchain.rllib.algorithm as algorithm_module
    seen = []
    real_play = algorithm_module.play

    def play(*args, deterministic, **kwargs):
        seen.append(deterministic)
        return real_play(*args, deterministic=deterministic, **kwargs)

    monkeypatch.setattr(algorithm_module, "play", play)
    monkeypatch.chdir(tmp_path)
    algo = PPOConfig().environment("CartPole-v1").training(train_batch_size=32, minibatch_size=16,
                                                           num_epochs=1).evaluation(evaluation_duration=1).build_algo()
    try:
        algo.evaluate()
        algo.config._settings["evaluation_config"] = {"explore": False}
        algo.evaluate()
    finally:
        algo.stop()
    assert seen == [False, True]  # sampled by default, greedy with explore=False
