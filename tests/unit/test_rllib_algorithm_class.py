"""``config.algo_class is PPO``, as in RLlib, where ``PPO`` (the face's exported name) is the algorithm class as
a callable Tune takes as a function trainable (rlchain/rllib/algorithm_class.py)."""

import copy
import pickle

import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithm import ALGORITHMS, Algorithm
from rlchain.rllib.algorithm_class import AlgorithmClass
from rlchain.rllib.algorithms import APPO, DQN, IMPALA, SAC, APPOConfig, DQNConfig, IMPALAConfig, SACConfig
from rlchain.rllib.algorithms.ppo import PPO, PPOConfig
from rlchain.rllib.config import AlgorithmConfig


@pytest.mark.parametrize("config_class,algo", [(PPOConfig, PPO), (APPOConfig, APPO), (IMPALAConfig, IMPALA),
                                               (DQNConfig, DQN), (SACConfig, SAC)])
def test_config_algo_class_is_the_exported_algorithm(config_class, algo):
    config = config_class()
    assert config.algo_class is algo
    assert config.copy().algo_class is algo
    assert algo.get_default_config().algo_class is algo
    assert pickle.loads(pickle.dumps(algo)) is algo  # Tune ships the trainable to its workers
    assert copy.deepcopy(config).algo_class is algo
    assert algo.cls is ALGORITHMS[algo.__name__] and algo.__name__ == algo.cls.__name__
    assert pickle.loads(pickle.dumps(algo.cls)) is algo.cls
    assert algo == algo.cls and hash(algo) == hash(algo.cls)


def test_it_stands_for_the_class():
    class Fake(PPO.cls):  # an instance without building a run
        def __init__(self):
            pass

    assert isinstance(Fake(), PPO) and not isinstance(Fake(), DQN) and isinstance(Fake(), Algorithm)
    assert issubclass(Fake, PPO) and not issubclass(Fake, DQN)
    assert PPO.from_checkpoint.__func__ is Algorithm.from_checkpoint.__func__
    assert repr(PPO) == "<class 'rlchain.rllib.algorithms.ppo.PPO'>"
    assert callable(PPO) and not isinstance(PPO, type)  # a callable Tune takes as a function trainable


def test_a_subclass_of_it_is_a_class_and_keeps_the_registry():
    class MyPPO(PPO):
        pass

    assert isinstance(MyPPO, type) and issubclass(MyPPO, PPO.cls)
    assert ALGORITHMS["PPO"] is PPO.cls  # a user's subclass does not take over RLlib's name
    config = PPOConfig(algo_class=MyPPO)
    assert config.algo_class is MyPPO  # the class given, as in RLlib


def test_building_without_an_algorithm_is_one_line():
    with pytest.raises(ConfigError, match="no algorithm to build"):
        AlgorithmConfig().environment("CartPole-v1").build_algo()
    assert AlgorithmClass.of(PPO.cls) is PPO


def test_default_resource_request_is_one_bundle_for_the_trials_own_process():
    tune = pytest.importorskip("ray.tune")
    request = PPO.default_resource_request(PPOConfig().env_runners(num_env_runners=2))
    assert isinstance(request, tune.PlacementGroupFactory) and request.bundles == [{"CPU": 1}]
    dict_config = PPOConfig().resources(num_cpus_for_main_process=2).learners(num_gpus_per_learner=1).to_dict()
    assert DQN.default_resource_request(dict_config).bundles == [{"CPU": 2, "GPU": 1}]


def test_a_trial_asks_for_the_learners_gpus_as_rllib_260_does():
    # gpus/fractional_gpus.py: num_gpus=0.5 on the new API stack asks Ray for no GPU (RLlib runs it on a CPU)
    from rlchain.rllib.algorithm_class import trial_gpus
    assert trial_gpus(PPOConfig().resources(num_gpus=0.5).to_dict().get) == 0
    assert trial_gpus(PPOConfig().learners(num_gpus_per_learner=0.5).to_dict().get) == 0.5
    assert trial_gpus(PPOConfig().learners(num_learners=2, num_gpus_per_learner=1).to_dict().get) == 2
    old_stack = PPOConfig().api_stack(enable_rl_module_and_learner=False).resources(num_gpus=0.5)
    assert trial_gpus(old_stack.to_dict().get) == 0.5
