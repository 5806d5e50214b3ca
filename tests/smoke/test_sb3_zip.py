"""SB3 .zip models loaded as data (rlchain.sb3.zip_format) fine-tune with an env and export to ONNX."""

import os

import numpy as np
import pytest
import torch

import rlchain
from rlchain.runs import checkpoint as ckpt

pytestmark = pytest.mark.smoke

DATA = os.path.join(os.path.dirname(__file__), os.pardir, "data", "sb3")


def test_an_archive_fine_tunes_with_an_env(tmp_path):
    model = rlchain.PPO.load(os.path.join(DATA, "ppo_cartpole.zip"), env="CartPole-v1", n_envs=2,
                             tensorboard_log=str(tmp_path), verbose=0, n_steps=32)
    before = model.policy.state_dict()["action_net.weight"].clone()
    model.learn(64)
    assert model.n_envs == 2 and model.num_timesteps == 64
    assert not torch.equal(before, model.policy.state_dict()["action_net.weight"])
    with pytest.raises(ValueError, match="spaces"):
        rlchain.PPO.load(os.path.join(DATA, "ppo_cartpole.zip"), env="Pendulum-v1")



def test_an_archive_exports_to_onnx(tmp_path):
    pytest.importorskip("onnxruntime")
    from rlchain.inference.export.onnx import verify_onnx

    model = rlchain.PPO.load(os.path.join(DATA, "ppo_pendulum.zip"))
    path = model.export_onnx(str(tmp_path / "ppo_pendulum.onnx"))
    obs = np.random.default_rng(0).uniform(-1, 1, (8, 3)).astype(np.float32)
    assert verify_onnx(model.policy.net, path, obs) < 1e-5


@pytest.mark.parametrize(("cls", "env_id"), [("PPO", "CartPole-v1"), ("PPO", "Pendulum-v1"), ("SAC", "Pendulum-v1"),
                                             ("DQN", "CartPole-v1")])
def test_save_to_zip_writes_sb3s_archive_that_both_load(tmp_path, cls, env_id):
    sb3 = pytest.importorskip("stable_baselines3")
    import gymnasium as gym

    model = getattr(rlchain, cls)("MlpPolicy", env_id, verbose=0, seed=0, policy_kwargs={"net_arch": [16]})
    path = model.save(str(tmp_path / "model.zip"))
    obs = np.stack([gym.make(env_id).reset(seed=s)[0] for s in range(4)])
    expected = model.predict(obs)[0]
    by_sb3 = getattr(sb3, cls).load(path, device="cpu")
    np.testing.assert_allclose(by_sb3.predict(obs, deterministic=True)[0].reshape(expected.shape), expected,
                               atol=1e-5)
    again = getattr(rlchain, cls).load(path)
    np.testing.assert_allclose(again.predict(obs)[0], expected, atol=1e-5)


def test_an_sb3_archive_as_a_checkpoint_is_named_and_set_parameters_reads_it(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=3, verbose=0, policy_kwargs={"net_arch": [8]})
    pytest.importorskip("stable_baselines3")
    path = model.save(str(tmp_path / "sb3.zip"))
    with pytest.raises(ckpt.CheckpointError) as exc:
        ckpt.load(path)
    one_line(exc, path, "a Stable-Baselines3 model archive", "rlchain.PPO.load(path)")
    other = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=4, verbose=0, policy_kwargs={"net_arch": [8]})
    obs = np.random.default_rng(0).normal(size=(6, 4)).astype(np.float32)
    other.set_parameters(path)
    np.testing.assert_allclose(other.predict(obs)[0], model.predict(obs)[0])
    small = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=4, verbose=0, policy_kwargs={"net_arch": [4]})
    with pytest.raises(ckpt.CheckpointError) as exc:
        small.set_parameters(path)
    one_line(exc, path, "its weights do not fit this model")


def one_line(exc_info, path, *parts):
    text = str(exc_info.value)
    assert text.startswith(f"{path}: ") and "\n" not in text, text
    for part in parts:
        assert part in text, text
