"""The names RLlib's example classes and scripts import resolve under the face (rlchain/rllib/examples,
utils/spaces, tune.py, policy/): RLlib's installed example envs and modules load with their ``ray.rllib``
imports answered by rlchain."""

import gymnasium as gym
import numpy as np
import pytest

from rlchain.rllib.utils.spaces.repeated import Repeated
from rlchain.rllib.utils.spaces.space_utils import batch, flatten_space


def test_space_helpers_as_rllibs_examples_call_them():
    space = gym.spaces.Dict({"b": gym.spaces.Discrete(3), "a": gym.spaces.Tuple((gym.spaces.Box(0, 1, (2,)),
                                                                                  gym.spaces.Discrete(2)))})
    assert flatten_space(space) == [gym.spaces.Box(0, 1, (2,)), gym.spaces.Discrete(2), gym.spaces.Discrete(3)]
    stacked = batch([{"x": np.zeros(2), "y": 1}, {"x": np.ones(2), "y": 2}])
    assert stacked["x"].shape == (2, 2) and stacked["y"].tolist() == [1, 2]
    assert Repeated(gym.spaces.Discrete(2), 3).contains([0, 1]) and not Repeated(gym.spaces.Discrete(2), 1).contains(
        [0, 1])


def test_installed_rllib_example_classes_import_under_the_face():
    pytest.importorskip("ray")
    from rlchain.rllib.examples import _rllib_examples_dir

    if _rllib_examples_dir() is None:
        pytest.skip("RLlib is not installed beside the face")
    from rlchain.rllib.alias import install, uninstall

    install()
    try:
        from ray.rllib.env.multi_agent_env import MultiAgentEnv
        from ray.rllib.examples.envs.classes.multi_agent import MultiAgentCartPole

        env = MultiAgentCartPole({"num_agents": 2})
        assert isinstance(env, MultiAgentEnv) and type(MultiAgentEnv).__module__ != "ray.rllib"
        assert MultiAgentEnv.__module__ == "rlchain.rllib.multi_agent"
        obs, _ = env.reset(seed=0)
        assert sorted(obs) == [0, 1]
    finally:
        uninstall()


def test_rllib_example_rl_modules_with_target_networks_import_under_the_face():
    pytest.importorskip("ray")
    from rlchain.rllib.examples import _rllib_examples_dir

    if _rllib_examples_dir() is None:
        pytest.skip("RLlib is not installed beside the face")
    from rlchain.rllib.alias import install, uninstall
    from rlchain.rllib.core.rl_module.torch import TorchRLModule

    install()
    try:  # it imports core.learner.utils, apis' TARGET_NETWORK_ACTION_DIST_INPUTS and utils.typing's NetworkType
        from ray.rllib.examples.rl_modules.classes.lstm_containing_rlm import LSTMContainingRLModule
        from ray.rllib.utils.typing import NetworkType, SampleBatchType, T  # noqa: F401

        assert issubclass(LSTMContainingRLModule, TorchRLModule)
    finally:
        uninstall()


def test_tune_trainable_gives_the_default_config():
    pytest.importorskip("ray.tune")
    from rlchain.rllib.algorithms.ppo import PPOConfig
    from rlchain.rllib.tune import make_trainable

    assert isinstance(make_trainable("PPO").get_default_config(), PPOConfig)


def test_tuner_of_the_algorithm_class_asking_for_checkpoints_gets_the_trainable_class():
    # ray_tune/appo_hyperparameter_tune.py: tune.Tuner(config.algo_class, run_config=RunConfig(checkpoint_config=
    # CheckpointConfig(checkpoint_at_end=True))): Tune refuses that for a function trainable; RLlib's is a class
    from types import SimpleNamespace

    from rlchain.rllib.algorithms.appo import APPO
    from rlchain.rllib.tune_hooks import trainable_for
    asks = SimpleNamespace(checkpoint_config=SimpleNamespace(checkpoint_at_end=True, checkpoint_frequency=0))
    every = SimpleNamespace(checkpoint_config=SimpleNamespace(checkpoint_at_end=False, checkpoint_frequency=5))
    plain = SimpleNamespace(checkpoint_config=SimpleNamespace(checkpoint_at_end=False, checkpoint_frequency=0))
    assert trainable_for(APPO, plain) is APPO and trainable_for(APPO, None) is APPO  # a function trainable
    assert trainable_for(len, asks) is len  # not a face algorithm: Tune's own rules
    pytest.importorskip("ray.tune")
    from ray import tune
    for run_config in (asks, every):
        trainable = trainable_for(APPO, run_config)
        assert isinstance(trainable, type) and issubclass(trainable, tune.Trainable)
        assert trainable.__name__ == "APPO" and trainable.get_default_config().algo_name == "APPO"
