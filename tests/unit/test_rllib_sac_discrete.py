"""The RLlib face's SAC on Discrete actions (rlchain.rllib.algorithms.sac): RLlib 2.60's discrete defaults
translated (its "auto" target entropy -1, the categorical actor and per-action critics of fcnet + head layers), one
training iteration with RLlib's learner results, the module's logits and actions, and other spaces refused."""

import math

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.off_policy.sac_discrete import DiscreteSoftActorCritic
from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.sac import SACConfig
from rlchain.rllib.algorithms.sac.translate import sac_config


def test_rllibs_discrete_defaults_map_onto_rlchains_discrete_sac():
    c = SACConfig().rl_module(model_config={"fcnet_hiddens": [64, 64], "fcnet_activation": "relu",
                                            "head_fcnet_hiddens": [32], "head_fcnet_activation": "relu"})
    params = sac_config(c, "CartPole-v1", {}, continuous=False)["params"]
    cfg, network = params["config"], params["network"]
    # RLlib's learner: target_entropy "auto" = -prod(action_space.shape) = -1 for Discrete (shape ())
    assert cfg["target_entropy"] == -1.0 and -np.prod(gym.spaces.Discrete(5).shape) == -1.0
    assert network["space"] == {"discrete": None} and network["mlp"]["units"] == [64, 64, 32]
    assert "log_std_bounds" not in network and cfg["log_std_bounds"] is None  # a Gaussian's clip, unused
    assert cfg["loss"] == "huber" and cfg["init_alpha"] == 1.0
    assert sac_config(SACConfig().training(target_entropy=0.5), "CartPole-v1", {}, continuous=False)["params"][
        "config"]["target_entropy"] == 0.5
    assert sac_config(SACConfig(), "Pendulum-v1", {})["params"]["config"]["target_entropy"] is None  # -action dims


def test_sac_trains_cartpole_and_its_module_gives_logits_and_int_actions(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = (SACConfig().environment("CartPole-v1")
            .training(train_batch_size_per_learner=8, num_steps_sampled_before_learning_starts=8)
            .rl_module(model_config={"fcnet_hiddens": [8]})
            .reporting(min_sample_timesteps_per_iteration=16).debugging(seed=1).build_algo())
    try:
        model = algo._stepper.context.agent.model
        assert isinstance(model, DiscreteSoftActorCritic)
        q1, _ = model.network.critic(torch.zeros(1, 4))
        assert q1.shape == (1, 2)  # one Q-value per action
        result = algo.train()
        learner = result["learners"]["default_policy"]
        assert learner["target_entropy"] == -1.0
        assert all(math.isfinite(learner[k]) for k in ("qf_loss", "qf_twin_loss", "policy_loss", "alpha_loss",
                                                        "alpha_value", "logps", "qf_mean", "td_error_mean"))
        assert result["env_runners"]["num_env_steps_sampled_lifetime"] == 16
        module = algo.get_module()
        logits = module.forward_inference({"obs": torch.zeros(3, 4)})["action_dist_inputs"]
        assert logits.shape == (3, 2)
        action = algo.compute_single_action(np.zeros(4, np.float32), explore=False)
        assert isinstance(action, int) and action == int(logits[0].argmax())
    finally:
        algo.stop()


class MultiDiscreteEnv(gym.Env):
    observation_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    action_space = gym.spaces.MultiDiscrete([2, 3])

    def __init__(self, config=None):
        pass

    def reset(self, *, seed=None, options=None):
        return np.zeros(2, np.float32), {}

    def step(self, action):
        return np.zeros(2, np.float32), 0.0, True, False, {}


def test_other_action_spaces_are_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=r"MultiDiscrete actions are not mapped by the face for SAC "
                                          r"\(Box or Discrete\)") as info:
        SACConfig().environment(MultiDiscreteEnv).build_algo()
    assert "\n" not in str(info.value)
