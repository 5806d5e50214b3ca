"""rlchain.sb3.names and rlchain.sb3.policy: SB3's parameter names over rlchain's networks."""

import gymnasium as gym
import numpy as np
import pytest
import torch

import rlchain
from rlchain.sb3.names import from_sb3, is_sb3_named, to_sb3

SB3_NAMES = {
    ("PPO", "CartPole-v1"): {"mlp_extractor.policy_net.0.weight", "mlp_extractor.policy_net.2.bias",
                             "mlp_extractor.value_net.2.weight", "action_net.weight", "value_net.bias"},
    ("PPO", "Pendulum-v1"): {"log_std", "action_net.weight", "mlp_extractor.value_net.0.bias"},
    ("SAC", "Pendulum-v1"): {"actor.latent_pi.0.weight", "actor.mu.weight", "actor.log_std.bias",
                             "critic.qf0.4.weight", "critic.qf1.2.bias", "critic_target.qf0.0.weight"},
    ("DQN", "CartPole-v1"): {"q_net.q_net.0.weight", "q_net.q_net.4.bias", "q_net_target.q_net.2.weight"},
}


@pytest.mark.parametrize(("cls", "env_id"), list(SB3_NAMES))
def test_policy_state_dict_has_sb3s_names_and_round_trips(cls, env_id):
    model = getattr(rlchain, cls)("MlpPolicy", env_id, verbose=0, seed=0)
    state = model.policy.state_dict()
    assert SB3_NAMES[(cls, env_id)] <= set(state) and is_sb3_named(cls.lower(), state)
    assert set(model.get_parameters()["policy"]) == set(state)
    own = model.policy.net.state_dict()
    back = from_sb3(cls.lower(), to_sb3(cls.lower(), own), own)
    assert set(back) == set(own) and all(torch.equal(back[k], own[k]) for k in own)
    other = getattr(rlchain, cls)("MlpPolicy", env_id, verbose=0, seed=1)
    other.policy.load_state_dict(state)
    obs = np.stack([gym.make(env_id).reset(seed=s)[0] for s in range(4)])
    np.testing.assert_array_equal(other.predict(obs)[0], model.predict(obs)[0])


def test_partial_load_with_strict_false_changes_only_those_parameters():
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", verbose=0, policy_kwargs={"net_arch": [32]})
    state = model.policy.state_dict()
    picked = {k: v + 1 for k, v in state.items() if "policy" in k or "action" in k}  # SB3's docs' selection
    assert sorted(picked) == ["action_net.bias", "action_net.weight", "mlp_extractor.policy_net.0.bias",
                              "mlp_extractor.policy_net.0.weight"]
    model.policy.load_state_dict(picked, strict=False)
    after = model.policy.state_dict()
    assert torch.equal(after["action_net.bias"], picked["action_net.bias"])
    assert torch.equal(after["value_net.weight"], state["value_net.weight"])


def test_sac_head_splits_into_mu_and_log_std():
    head = torch.arange(8.0).reshape(4, 2)  # 2 actions: rows 0-1 mu, rows 2-3 log_std
    state = to_sb3("sac", {"network.actor.trunk.0.weight": head})
    np.testing.assert_array_equal(state["actor.mu.weight"], head[:2])
    np.testing.assert_array_equal(state["actor.log_std.weight"], head[2:])


def test_policy_predict_clips_box_actions_to_the_bounds():
    model = rlchain.PPO("MlpPolicy", "Pendulum-v1", verbose=0, policy_kwargs={"log_std_init": 3.0})
    obs = np.zeros((64, 3), np.float32)
    actions, state = model.policy.predict(obs, deterministic=False)
    assert state is None and actions.min() >= -2.0 and actions.max() <= 2.0
