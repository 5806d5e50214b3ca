"""An env with Discrete observations (FrozenLake, RLlib's curriculum example) trains on the face: its
observations reach the network one-hot, as RLlib's ``FlattenObservations`` connector gives them."""

import gymnasium as gym
import numpy as np

from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.connectors.env_to_module import FlattenObservations
from rlchain.rllib.envs import env_maker


def test_discrete_observations_are_one_hot_and_box_ones_untouched():
    make, _ = env_maker("FrozenLake-v1", {"is_slippery": False}, 0, 1)
    env = make(0)
    obs, _ = env.reset(seed=0)
    assert env.observation_space == gym.spaces.Box(0, 1, (16,), np.int64) and obs.tolist() == [1] + [0] * 15
    assert make.flattened
    cartpole, _ = env_maker("CartPole-v1", {}, 0, 1)
    assert cartpole(0).observation_space.shape == (4,) and not cartpole.flattened


def test_frozenlake_with_flatten_observations_trains(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment("FrozenLake-v1", env_config={"is_slippery": False})
            .env_runners(num_envs_per_env_runner=2, env_to_module_connector=lambda env: FlattenObservations())
            .training(train_batch_size=64, minibatch_size=32, num_epochs=1).debugging(seed=0).build_algo())
    try:
        result = algo.train()
        assert result["num_env_steps_sampled_lifetime"] == 64
        assert algo.observation_space.shape == (16,)
    finally:
        algo.stop()


def test_a_frozenlake_modules_checkpoint_reads_one_hot_observations(tmp_path, monkeypatch):
    import torch

    from rlchain.rllib.core.rl_module import RLModule

    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment("FrozenLake-v1").env_runners(num_env_runners=0)
            .training(train_batch_size=32, minibatch_size=16, num_epochs=1).build_algo())
    try:
        algo.train()
        path = algo.save_to_path(str(tmp_path / "ckpt"))
        obs = torch.eye(16)[:3]
        trained = algo.get_module().forward_inference({"obs": obs})["action_dist_inputs"]
    finally:
        algo.stop()
    module = RLModule.from_checkpoint(f"{path}/learner_group/learner/rl_module/default_policy")
    assert module.observation_space.shape == (16,)  # the one-hot space the network trained on, not Discrete(16)
    assert torch.allclose(module.forward_inference({"obs": obs})["action_dist_inputs"], trained)
