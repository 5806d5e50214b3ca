"""rlchain.envs.backends.sb3_vecenv: a Stable-Baselines3 VecEnv under rlchain's VecEnv contract."""

import gymnasium as gym
import numpy as np
import pytest

sb3_vec_env = pytest.importorskip("stable_baselines3.common.vec_env")

from rlchain.envs.backends.sb3_vecenv import SB3VecEnv, is_sb3_vecenv, vec_normalize_of  # noqa: E402


class Counter(gym.Env):
    """obs = steps taken; terminates at 3 steps when ``terminate``, else a 3-step TimeLimit cuts it."""

    observation_space = gym.spaces.Box(-10, 10, (1,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, terminate: bool) -> None:
        self.terminate = terminate
        self.t = 0

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return np.array([0.0], np.float32), {}

    def step(self, action):
        self.t += 1
        return np.array([float(self.t)], np.float32), 1.0, self.terminate and self.t >= 3, False, {}


def _venv():
    return sb3_vec_env.DummyVecEnv([lambda: Counter(True), lambda: gym.wrappers.TimeLimit(Counter(False), 3)])


def test_recognises_sb3_vec_envs_and_their_wrappers():
    venv = _venv()
    assert is_sb3_vecenv(venv)
    normalized = sb3_vec_env.VecNormalize(venv)
    assert is_sb3_vecenv(normalized) and vec_normalize_of(normalized) is normalized
    assert vec_normalize_of(venv) is None
    assert not is_sb3_vecenv(gym.make("CartPole-v1"))


def test_terminal_observation_and_time_limit_become_final_obs_and_truncated():
    env = SB3VecEnv(_venv())
    assert env.num_envs == 2 and env.observation_space.shape == (1,)
    obs = env.reset(seed=0)
    assert obs.dtype == np.float32 and obs.shape == (2, 1)
    for _ in range(2):
        result = env.step(np.zeros(2, np.int64))
        assert not (result.terminated | result.truncated).any()
    result = env.step(np.zeros(2, np.int64))
    assert result.terminated.tolist() == [True, False]  # env 0 ended itself
    assert result.truncated.tolist() == [False, True]  # env 1 was cut by its TimeLimit
    np.testing.assert_array_equal(result.final_obs[:, 0], [3.0, 3.0])  # SB3's terminal_observation
    np.testing.assert_array_equal(result.obs[:, 0], [0.0, 0.0])  # already the next episode's first obs
    assert [sorted(i) for i in result.infos["sb3_infos"]][0] == ["TimeLimit.truncated", "terminal_observation"]
    assert result.game_reward is None


def test_vec_normalize_statistics_update_and_episode_rewards_stay_unnormalized():
    normalized = sb3_vec_env.VecNormalize(_venv(), norm_reward=True)
    env = SB3VecEnv(normalized)
    env.reset(seed=0)
    result = env.step(np.zeros(2, np.int64))
    assert normalized.obs_rms.count > 1  # SB3's running statistics are the ones updated
    np.testing.assert_array_equal(result.game_reward, [1.0, 1.0])  # the env's own reward, for episode statistics
    assert result.game_over.tolist() == [False, False]


def test_close_leaves_the_callers_vec_env_open():
    venv = _venv()
    SB3VecEnv(venv).close()
    assert venv.reset().shape == (2, 1)


def test_a_dict_observation_space_is_split_back_per_key_for_a_multi_input_network():
    from rlchain.envs.factory import keep_keys_apart

    space = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (2, 2, 1), np.uint8), "mode": gym.spaces.Discrete(3)})

    class Keyed(Counter):
        observation_space = space

        def reset(self, seed=None, options=None):
            super().reset(seed=seed)
            return {"image": np.full((2, 2, 1), 7, np.uint8), "mode": 2}, {}

    env = keep_keys_apart(SB3VecEnv(sb3_vec_env.DummyVecEnv([lambda: Keyed(True)] * 2)))
    assert env.observation_space == space
    obs = env.reset()
    assert obs["mode"].tolist() == [2, 2] and obs["image"].dtype == np.uint8 and (obs["image"] == 7).all()
