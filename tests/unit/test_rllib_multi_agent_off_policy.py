"""RLlib's DQN and SAC on a MultiAgentEnv through the face (rlchain/rllib/multi_agent_off_policy.py): each policy
rlchain's off-policy agent, RLlib's multi-agent results with a learner per trained policy."""

import numpy as np
import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.dqn import DQNConfig
from rlchain.rllib.algorithms.sac import SACConfig
from rlchain.rllib.env.multi_agent_env import make_multi_agent

from .test_rllib_multi_agent import TakeTurns


def test_dqn_trains_a_policy_per_player_of_a_turn_based_env(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = (DQNConfig().environment(TakeTurns).debugging(seed=1)
              .training(train_batch_size=8, num_steps_sampled_before_learning_starts=8, n_step=(1, 3))
              .reporting(min_sample_timesteps_per_iteration=32)
              .multi_agent(policies={"first", "second"}, policy_mapping_fn=lambda aid, *a, **kw: ["first",
                                                                                                  "second"][aid]))
    algo = config.build_algo()
    try:
        result = algo.train()
        assert result["env_runners"]["episode_len_mean"] == 4  # one move a step: 4 env steps a game
        assert set(result["learners"]) == {"first", "second", "__all_modules__"}
        for pid in ("first", "second"):
            assert np.isfinite(result["learners"][pid]["qf_loss"]) and result["learners"][pid]["curr_epsilon"] < 1
            assert result["learners"][pid]["num_module_steps_trained"] > 0
        algorithm = algo._stepper.context.algorithm
        # each player acts every other step: its transitions run move to move, one per move it made
        moves = {lr.name: lr.buffer.size for lr in algorithm.policies}
        assert moves["first"] == moves["second"] == 16
        assert algorithm.learner("second").buffer.rewards[:16].max() >= 10  # the bonus it got while waiting
        assert algo.evaluate()["env_runners"]["episode_len_mean"] == 4  # every policy plays its player
        path = algo.save_to_path(str(tmp_path / "ckpt"))
        weights = {k: v.clone() for k, v in algo.get_module("first").state_dict().items()}
        algo.train()
        algo.restore_from_path(path)
        assert all(torch.equal(weights[k], v) for k, v in algo.get_module("first").state_dict().items())
    finally:
        algo.stop()


def test_sac_trains_a_policy_per_agent_with_box_actions(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = (SACConfig().environment(make_multi_agent("Pendulum-v1"), env_config={"num_agents": 2})
              .training(train_batch_size_per_learner=8, num_steps_sampled_before_learning_starts=8)
              .reporting(min_sample_timesteps_per_iteration=16)
              .multi_agent(policies={"p0", "p1"}, policy_mapping_fn=lambda aid, *a, **kw: f"p{aid}",
                           policies_to_train=["p1"]))
    algo = config.build_algo()
    try:
        result = algo.train()
        assert set(result["learners"]) == {"p1", "__all_modules__"}  # p0 acts without learning
        assert np.isfinite(result["learners"]["p1"]["qf_loss"]) and result["learners"]["p1"]["alpha_value"] > 0
    finally:
        algo.stop()


def test_dqn_refuses_box_actions_in_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = DQNConfig().environment(make_multi_agent("Pendulum-v1"), env_config={"num_agents": 2})
    with pytest.raises(ConfigError, match="policy 'default_policy': Box actions are not mapped by the face for DQN"):
        config.build_algo()
