"""SB3 .zip models loaded as data (rlchain.sb3.zip_format) fine-tune with an env and export to ONNX."""

import os

import numpy as np
import pytest
import torch

import rlchain

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
