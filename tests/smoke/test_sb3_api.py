"""rlchain.PPO / SAC / DQN in Stable-Baselines3's shape: env objects and callables, learn, predict, save / load,
parameters, and the rl_games-style config they ran."""

import gymnasium as gym
import numpy as np
import pytest

import rlchain
from rlchain import Runner

pytestmark = pytest.mark.smoke


def quiet(tmp_path):
    return {"verbose": 0, "tensorboard_log": str(tmp_path / "runs")}


def test_top_level_names_are_the_sb3_classes():
    from rlchain.sb3 import DQN, PPO, SAC
    assert (rlchain.PPO, rlchain.SAC, rlchain.DQN) == (PPO, SAC, DQN)


def test_gymnasium_env_object_trains_and_stays_open(tmp_path):
    env = gym.make("CartPole-v1")
    model = rlchain.PPO("MlpPolicy", env, n_steps=64, batch_size=64, seed=3, **quiet(tmp_path))
    assert model.n_envs == 1
    model.learn(128)
    assert model.num_timesteps == 128 and model.result.epoch == 2
    assert env.spec.id == "CartPole-v1"  # rlchain stepped it without taking it over
    obs, _ = env.reset(seed=0)
    action, state = model.predict(obs)
    assert env.action_space.contains(int(action)) and state is None
    model.learn(64, reset_num_timesteps=False)  # resumes the run from its last checkpoint
    assert model.num_timesteps == 192
    model.learn(64)  # SB3's default: a new run from the current weights, the count from 0
    assert model.num_timesteps == 64


def test_callable_and_vector_env(tmp_path):
    model = rlchain.PPO("MlpPolicy", lambda: gym.make("CartPole-v1"), n_envs=2, n_steps=32, batch_size=32,
                        **quiet(tmp_path)).learn(64)
    assert model.result.frames == 64
    vec = gym.vector.SyncVectorEnv([lambda: gym.make("CartPole-v1")] * 3)
    model = rlchain.PPO("MlpPolicy", vec, n_steps=16, batch_size=48, **quiet(tmp_path))
    assert model.n_envs == 3 and model.learn(48).result.frames == 48
    with pytest.raises(ValueError, match="n_envs: 2, but a gymnasium env object"):
        rlchain.PPO("MlpPolicy", gym.make("CartPole-v1"), n_envs=2)


@pytest.mark.parametrize(("cls", "env_id"), [("PPO", "CartPole-v1"), ("PPO", "Pendulum-v1"),
                                             ("SAC", "Pendulum-v1"), ("DQN", "CartPole-v1")])
def test_save_load_predict_round_trip(tmp_path, cls, env_id):
    model = getattr(rlchain, cls)("MlpPolicy", env_id, seed=1, **quiet(tmp_path))
    env = gym.make(env_id)
    obs = np.stack([env.reset(seed=s)[0] for s in range(8)])
    path = model.save(str(tmp_path / "model"))
    assert path.endswith("model.zip")  # SB3's name for a path without an extension
    loaded = getattr(rlchain, cls).load(str(tmp_path / "model"))
    np.testing.assert_array_equal(loaded.predict(obs)[0], model.predict(obs)[0])
    single, _ = loaded.predict(obs[0])
    assert np.shape(single) == env.action_space.shape and env.action_space.contains(
        single.astype(env.action_space.dtype) if env.action_space.shape else int(single))
    params = model.get_parameters()
    other = getattr(rlchain, cls)("MlpPolicy", env_id, seed=2, **quiet(tmp_path))
    other.set_parameters(params)
    np.testing.assert_array_equal(other.predict(obs)[0], model.predict(obs)[0])


def test_the_config_it_runs_is_an_rl_games_yaml(tmp_path):
    model = rlchain.SAC("MlpPolicy", "Pendulum-v1", buffer_size=5000, batch_size=64, **quiet(tmp_path))
    path = model.save_config(str(tmp_path / "sac.yaml"), total_timesteps=1000)
    params = Runner().load(path).params
    assert params.algo.name == "sac" and params.config.replay_buffer_size == 5000
    assert params.config.batch_size == 64 and params.config.max_frames == 1000
    with pytest.raises(ValueError, match=r"^rlchain.SAC.save_config: total_timesteps: pass the frames"):
        model.save_config(str(tmp_path / "endless.yaml"))  # a YAML without max_frames would never stop
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", n_steps=32, batch_size=32, **quiet(tmp_path)).learn(64)
    assert Runner().load(model.save_config(str(tmp_path / "ppo.yaml"))).params.config.max_frames == 64


def test_unknown_argument_is_one_line(tmp_path):
    with pytest.raises(ValueError, match=r"^rlchain.DQN: exploration_fractio: unknown argument; did you mean "
                                         r"'exploration_fraction'"):
        rlchain.DQN("MlpPolicy", "CartPole-v1", exploration_fractio=0.1)
    with pytest.raises(ValueError, match="NatureCNN needs image observations"):
        rlchain.PPO("CnnPolicy", "CartPole-v1")  # CnnPolicy is SB3's NatureCNN: images only, as in SB3
    with pytest.raises(ValueError, match="'TdPolicy' is not supported"):
        rlchain.PPO("TdPolicy", "CartPole-v1")
