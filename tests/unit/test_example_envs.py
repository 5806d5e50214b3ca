"""The rl_games-style test envs: the memory env TestRnnEnv-v0 and the asymmetric TestAsymmetricEnv-v0."""

import gymnasium as gym
import numpy as np
import pytest

import rlchain  # noqa: F401  (registers the test envs)
from rlchain.envs.examples.asymmetric import TestAsymmetricCritic
from rlchain.envs.examples.rnn_env import TestRNNEnv
from rlchain.envs.factory import make_vec_env

MOVES = {(1, 0): 0, (-1, 0): 1, (0, 1): 2, (0, -1): 3}


def remember_goal_and_walk(env, obs):
    """The policy a memory makes possible: read the goal once, walk to it (the first action is lost)."""
    goal, pos = obs[2:4].copy(), np.zeros(2)
    obs, reward, terminated, truncated, info = env.step(0)
    while not (terminated or truncated):
        step = (np.sign(goal[0] - pos[0]), 0) if goal[0] != pos[0] else (0, np.sign(goal[1] - pos[1]))
        pos += step
        obs, reward, terminated, truncated, info = env.step(MOVES[(int(step[0]), int(step[1]))])
    return reward, terminated, info


def test_rnn_env_goal_is_shown_once_then_remembered():
    env = TestRNNEnv(hide_object=True)
    for seed in range(50):
        obs, _ = env.reset(seed=seed)
        assert obs[4] == 1 and obs[5] == 0 and (np.abs(obs[2:4]) >= 2).all() and (np.abs(obs[2:4]) <= 8).all()
        reward, terminated, info = remember_goal_and_walk(env, obs)
        assert terminated and reward == 1.0 and info == {"scores": 1}


def test_rnn_env_later_observations_do_not_depend_on_the_goal():
    """Two episodes with different goals look the same after the first observation until one ends:
    no feedforward policy can act on the goal, a recurrent one can."""
    a, b = TestRNNEnv(hide_object=True), TestRNNEnv(hide_object=True)
    obs_a, obs_b = a.reset(seed=0)[0], b.reset(seed=1)[0]
    assert not np.array_equal(obs_a[2:4], obs_b[2:4])
    for action in [2, 0, 0, 0, 3, 1]:
        (obs_a, reward_a, ta, _, _), (obs_b, reward_b, tb, _, _) = a.step(action), b.step(action)
        assert np.array_equal(obs_a, obs_b) and obs_a[4] == 0 and not (ta or tb) and reward_a == reward_b == 0
    assert a.pos.tolist() == [2, -1]  # the first action (2) was ignored


def test_rnn_env_options():
    env = TestRNNEnv(hide_object=True, show_time=3, max_steps=4)
    obs, _ = env.reset(seed=0)
    shown = [obs[4]] + [env.step(0)[0][4] for _ in range(3)]
    assert shown == [1, 1, 1, 0]
    env.reset(seed=0)
    for _ in range(3):
        assert not env.step(1)[3]
    _, reward, terminated, truncated, info = env.step(1)
    assert truncated and not terminated and reward == 0 and info == {"scores": 0}

    multi = TestRNNEnv(multi_discrete_space=True, multi_head_value=True, apply_dist_reward=True,
                       multi_obs_space=True, aux_loss=True)
    assert isinstance(multi.action_space, gym.spaces.Tuple) and multi.value_size == 2
    obs, _ = multi.reset(seed=0)
    assert set(obs) == {"pos", "info", "aux_target"} and multi.observation_space.contains(obs)
    multi.step((0, 2))
    obs, reward, *_ = multi.step((0, 2))  # x + 1, y stays
    assert obs["pos"].tolist() == [1, 0] and reward.shape == (2,) and reward[1] < 0

    central = TestRNNEnv(hide_object=True, use_central_value=True)
    obs, _ = central.reset(seed=0)
    obs, *_ = central.step(0)
    assert set(obs) == {"obs", "state"} and central.observation_space.contains(obs)
    assert obs["obs"][2:4].tolist() == [0, 0] and obs["state"][2:4].tolist() == central.goal.tolist()


def test_rnn_env_is_registered_under_rl_games_names():
    assert gym.spec("TestRnnEnv-v0") is not None
    env = make_vec_env("test_env", {"name": "TestRnnEnv-v0", "hide_object": True}, 3, 0, None)
    try:
        obs = env.reset(seed=0)
        assert obs.shape == (3, 6) and env.action_space == gym.spaces.Discrete(4)
        assert (env.step(np.zeros(3, dtype=np.int64)).obs[:, 2:5] == 0).all()
    finally:
        env.close()


def test_asymmetric_env_contract():
    env = gym.make("TestAsymmetricEnv-v0")
    assert env.unwrapped.use_central_value is True
    assert set(env.observation_space.spaces) == {"obs", "state"} and env.unwrapped.state_space.shape == (4,)
    obs, _ = env.reset(seed=0)
    for _ in range(3):
        assert env.observation_space.contains(obs)
        assert obs["obs"][[1, 3]].tolist() == [0, 0] and obs["state"][[1, 3]].any()  # velocities hidden
        np.testing.assert_array_equal(obs["obs"][[0, 2]], obs["state"][[0, 2]])
        obs, reward, terminated, truncated, _ = env.step(0)
        assert reward == 1.0
    env.close()


def test_asymmetric_env_options():
    plain = TestAsymmetricCritic(use_central_value=False)
    obs, _ = plain.reset(seed=0)
    assert isinstance(plain.observation_space, gym.spaces.Box) and obs[1] == 0 and obs[3] == 0
    unmasked = TestAsymmetricCritic(apply_mask=False)
    obs, _ = unmasked.reset(seed=0)
    np.testing.assert_array_equal(obs["obs"], obs["state"])
    pendulum = TestAsymmetricCritic("Pendulum-v0")  # rl_games' old id
    obs, _ = pendulum.reset(seed=0)
    assert obs["obs"][2] == 0 and obs["state"].shape == (3,)
    with pytest.raises(ValueError, match="no velocity mask for 'FrozenLake-v1'"):
        TestAsymmetricCritic("FrozenLake-v1")


def test_asymmetric_env_through_the_vecenv():
    env = make_vec_env("openai_gym", {"name": "TestAsymmetricEnv-v0"}, 2, 0, None)
    try:
        space = env.observation_space
        assert (space.obs_size, space.state_size) == (4, 4)  # [obs | state] per env
        obs = env.reset(seed=0)
        assert obs.shape == (2, 8) and (obs[:, [1, 3]] == 0).all() and obs[:, [5, 7]].any()
    finally:
        env.close()


@pytest.mark.parametrize("central", [True, False])
def test_dict_observations_reach_the_trainer_flat_with_their_dict_space(central):
    """multi_obs_space (+ use_central_value): flattened by gymnasium's rule, the Dict kept for networks."""
    from rlchain.envs.wrappers.central_value import ObsStateBox

    env = make_vec_env("test_env", {"name": "TestRnnEnv-v0", "multi_obs_space": True, "aux_loss": True,
                                    "use_central_value": central}, 2, 0, None)
    obs = np.asarray(env.reset(0))
    single = TestRNNEnv(multi_obs_space=True, aux_loss=True, use_central_value=central)
    first, _ = single.reset(seed=0)
    space = env.observation_space
    if central:
        assert isinstance(space, ObsStateBox) and space.obs_size == space.state_size == 7
        assert set(space.obs_space.spaces) == {"aux_target", "info", "pos"} and space.state_space is not None
        expected = np.concatenate([gym.spaces.flatten(space.obs_space, first["obs"]),
                                   gym.spaces.flatten(space.state_space, first["state"])])
    else:
        assert space.shape == (7,) and set(space.dict_space.spaces) == {"aux_target", "info", "pos"}
        expected = gym.spaces.flatten(space.dict_space, first)
    assert obs.shape == (2, expected.shape[0]) and obs.dtype == np.float32
    assert np.allclose(obs[0], expected)
    env.close()
