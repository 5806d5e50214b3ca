"""``symmetry``: mirror maps (rlchain/algos/core/symmetry.py) and PPO's mirror loss."""

import copy

import pytest
import torch

from rlchain.algos.core.symmetry import (
    G1_JOINTS,
    GO1_JOINTS,
    MirrorMap,
    augmented_storage,
    g1,
    go1,
    mirrored_params,
    resolve_mirror,
)
from rlchain.config.errors import ConfigError
from tests.conftest import ppo_epochs


def pendulum_mirror(obs_size, action_size):
    """Pendulum's reflection: (cos, sin, angular velocity) -> (cos, -sin, -angular velocity), torque -> -torque."""
    return MirrorMap((0, 1, 2), (1.0, -1.0, -1.0), (0,), (-1.0,))


def go1_obs(batch=2):
    """Go1 actor observations whose every feature is its own index + 1 (so a mirror shows where each went)."""
    return torch.arange(1.0, 49.0).repeat(batch, 1)


def test_go1_map_swaps_left_and_right_legs_and_flips_the_lateral_axes():
    mirror = go1(48, 12)
    obs = go1_obs()
    out = mirror.mirror_obs(obs)[0]
    assert out[:9].tolist() == [1, -2, 3, -4, 5, -6, 7, -8, 9]  # lin vel, ang vel, gravity
    fr_hip, fl_hip, fl_thigh = 9 + GO1_JOINTS.index("FR_hip_joint"), 9 + GO1_JOINTS.index("FL_hip_joint"), \
        9 + GO1_JOINTS.index("FL_thigh_joint")
    fr_thigh = 9 + GO1_JOINTS.index("FR_thigh_joint")
    assert out[fr_hip] == -(fl_hip + 1) and out[fl_hip] == -(fr_hip + 1)  # hip abduction: swapped and negated
    assert out[fr_thigh] == fl_thigh + 1  # thigh: swapped only
    assert out[21 + GO1_JOINTS.index("RL_calf_joint")] == 21 + GO1_JOINTS.index("RR_calf_joint") + 1  # velocities
    assert out[45:].tolist() == [46, -47, -48]  # command: vx, -vy, -yaw rate
    torch.testing.assert_close(mirror.mirror_obs(mirror.mirror_obs(obs)), obs)  # a mirror of a mirror
    actions = torch.arange(1.0, 13.0).unsqueeze(0)
    torch.testing.assert_close(mirror.mirror_actions(mirror.mirror_actions(actions)), actions)
    assert mirror.mirror_actions(actions)[0, 0] == -4  # FR hip <- -FL hip


def test_g1_map_negates_roll_and_yaw_joints_only():
    mirror = g1(99, 29)
    actions = torch.arange(1.0, 30.0).unsqueeze(0)
    out = mirror.mirror_actions(actions)[0]
    for i, name in enumerate(G1_JOINTS):
        other = name.replace("left_", "@").replace("right_", "left_").replace("@", "right_")
        sign = -1 if "roll" in name or "yaw" in name else 1
        assert out[i] == sign * (G1_JOINTS.index(other) + 1), name
    with pytest.raises(ValueError, match="actor observation of 99 and 29 actions"):
        g1(48, 12)


def test_resolve_mirror_takes_shipped_names_and_module_functions():
    assert resolve_mirror("go1", 48, 12) == go1(48, 12)
    assert resolve_mirror("tests.unit.test_symmetry:pendulum_mirror", 3, 1).act_sign == (-1.0,)
    with pytest.raises(ValueError, match="neither a shipped mirror map"):
        resolve_mirror("go2", 48, 12)
    with pytest.raises(ValueError, match="permutation"):
        MirrorMap((0, 0), (1.0, 1.0), (0,), (1.0,))


PENDULUM = {
    "params": {
        "seed": 1, "algo": {"name": "a2c_continuous"}, "model": {"name": "continuous_a2c_logstd"},
        "network": {"name": "actor_critic", "separate": False, "mlp": {"units": [16]},
                    "space": {"continuous": {"fixed_sigma": True}}},
        "config": {"name": "t", "env_name": "Pendulum-v1", "device": "cpu", "num_actors": 4, "horizon_length": 8,
                   "minibatch_size": 16, "mini_epochs": 1, "normalize_input": False},
    }
}


def test_ppo_minimises_the_mirror_loss():
    config = copy.deepcopy(PENDULUM)
    config["params"]["config"]["symmetry"] = {"mirror": "tests.unit.test_symmetry:pendulum_mirror",
                                              "mirror_loss_coef": 1.0}
    stats, ppo = ppo_epochs(config, [], 4, 1)
    assert stats[0]["mirror_loss"] >= 0
    loss = ppo.mirror_loss
    obs = torch.randn(256, 3)
    before = float(loss.loss(obs).detach())
    for _ in range(100):
        loss.train_on(obs, 64)
    assert float(loss.loss(obs).detach()) < 0.1 * before  # the policy became (nearly) odd in (sin, angular velocity)


def test_symmetry_needs_continuous_actions(base_config):
    config = copy.deepcopy(base_config)
    config["params"]["config"]["symmetry"] = {"mirror": "go1"}
    with pytest.raises(ConfigError, match="continuous"):
        ppo_epochs(config, [], 4, 1)
    config = copy.deepcopy(PENDULUM)
    config["params"]["config"]["symmetry"] = {"mirror": "go1"}
    with pytest.raises(ConfigError, match=r"symmetry\.mirror.*velocity tasks"):
        ppo_epochs(config, [], 4, 1)


def test_the_augmented_rollout_holds_the_mirror_images_with_the_originals_advantages():
    config = copy.deepcopy(PENDULUM)
    config["params"]["config"]["symmetry"] = {"mirror": "tests.unit.test_symmetry:pendulum_mirror",
                                              "mirror_loss_coef": 0.0, "data_augmentation": True}
    stats, ppo = ppo_epochs(config, [], 4, 2)  # the update trains on the doubled rollout
    assert "mirror_loss" not in stats[0] and stats[1]["a_loss"] == stats[1]["a_loss"]
    storage, mirror = ppo.storage, ppo.mirror_loss.mirror
    out = augmented_storage(storage, mirror, None)
    assert out.obs.shape == (8, 8, 3) and out.num_envs == 8 and storage.num_envs == 4
    torch.testing.assert_close(out.obs[:, 4:], storage.obs * torch.tensor([1.0, -1.0, -1.0]))
    torch.testing.assert_close(out.actions[:, 4:], -storage.actions)
    torch.testing.assert_close(out.advantages[:, 4:], storage.advantages)
    torch.testing.assert_close(out.log_probs[:, 4:], storage.log_probs)
    params = torch.tensor([[0.5, 2.0]])
    assert mirrored_params(params, mirror).tolist() == [[-0.5, 2.0]]  # the mean mirrored, the scale kept
    batches = list(out.minibatches(16, out.advantages.sum(-1)))
    assert len(batches) == 4 and all(b.obs.shape == (16, 3) for b in batches)
