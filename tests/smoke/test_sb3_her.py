"""SB3's HER page on rlchain (import swapped): MultiInputPolicy with replay_buffer_class=HerReplayBuffer on SB3's
BitFlippingEnv object, trains, saves, loads with the env and plays with Dict observations."""

import numpy as np
import pytest

import rlchain
from rlchain import HerReplayBuffer

pytest.importorskip("stable_baselines3")
from stable_baselines3.common.envs import BitFlippingEnv  # noqa: E402

pytestmark = pytest.mark.smoke


@pytest.mark.parametrize("algo", ["DQN", "SAC"])
def test_her_page_runs(tmp_path, algo):
    env = BitFlippingEnv(n_bits=4, continuous=algo == "SAC", max_steps=4)
    cls = getattr(rlchain, algo)
    model = cls("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future"},
                learning_starts=16, batch_size=16, verbose=0, tensorboard_log=str(tmp_path / "runs"))
    assert model.config["params"]["config"]["replay"] == {"her": {"strategy": "future", "k": 4}}
    model.learn(64)
    path = model.save(str(tmp_path / "her_bit_env"))
    loaded = cls.load(str(tmp_path / "her_bit_env"), env=env)
    obs, _ = env.reset(seed=0)
    for _ in range(8):
        action, _ = loaded.predict(obs, deterministic=True)
        assert np.array_equal(action, model.predict(obs, deterministic=True)[0])
        obs, reward, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            obs, _ = env.reset()
    assert path.endswith(".zip")
