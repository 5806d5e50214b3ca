"""``ray.rllib.algorithms.ppo.ppo_catalog.PPOCatalog`` as a module spec's ``catalog_class``
(pretraining_single_agent_training_multi_agent.py): the face's PPO module builds from ``model_config`` with it."""

import gymnasium as gym
import torch

from rlchain.rllib.algorithms.ppo.ppo_catalog import PPOCatalog
from rlchain.rllib.algorithms.ppo.torch.ppo_torch_rl_module import PPOTorchRLModule
from rlchain.rllib.core.columns import Columns
from rlchain.rllib.core.rl_module.default_model_config import DefaultModelConfig
from rlchain.rllib.core.rl_module.rl_module import RLModuleSpec


def test_a_spec_naming_ppos_catalog_builds_the_default_ppo_module():
    spec = RLModuleSpec(module_class=PPOTorchRLModule, observation_space=gym.spaces.Box(-1, 1, (4,)),
                        action_space=gym.spaces.Discrete(2), model_config=DefaultModelConfig(fcnet_hiddens=[32]),
                        catalog_class=PPOCatalog)
    module = spec.build()
    assert module.catalog_class is PPOCatalog
    out = module.forward_inference({"obs": torch.zeros(3, 4)})
    assert out[Columns.ACTION_DIST_INPUTS].shape == (3, 2)
