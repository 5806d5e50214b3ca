"""``model.save("name")`` writes ``name.zip`` as SB3 does (SB3's layout with rlchain's model file inside), and the
attributes and calls SB3's export and save-format guides use: ``model.observation_space``, ``learning_rate``,
``gamma``, ``env``, ``policy(obs, deterministic=True)``, SAC's ``policy.actor`` traced to ONNX and TorchScript,
``load(..., print_system_info=True)``."""

import zipfile

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

import rlchain
from rlchain.sb3.model_zip import MEMBER

pytestmark = pytest.mark.smoke


def quiet(tmp_path):
    return {"verbose": 0, "tensorboard_log": str(tmp_path / "runs")}


class Doubler(nn.Module):
    """A features extractor that is a plain module with ``features_dim`` (rlchain's base not needed)."""

    def __init__(self, observation_space, features_dim=6):
        super().__init__()
        self.features_dim = features_dim
        self.linear = nn.Linear(observation_space.shape[0], features_dim)

    def forward(self, obs):
        return 2 * self.linear(obs)


def test_save_without_a_suffix_writes_a_zip_sb3_and_rlchain_both_load(tmp_path):
    sb3 = pytest.importorskip("stable_baselines3")
    model = rlchain.PPO("MlpPolicy", "Pendulum-v1", seed=0, **quiet(tmp_path))
    path = model.save(str(tmp_path / "PathToTrainedModel"))
    assert path.endswith("PathToTrainedModel.zip") and MEMBER in zipfile.ZipFile(path).namelist()
    obs = np.stack([gym.make("Pendulum-v1").reset(seed=s)[0] for s in range(3)])
    by_sb3 = sb3.PPO.load(path, device="cpu")
    np.testing.assert_allclose(by_sb3.predict(obs, deterministic=True)[0], model.predict(obs)[0], atol=1e-5)
    loaded = rlchain.PPO.load(str(tmp_path / "PathToTrainedModel.zip"), device="cpu")
    assert loaded.config["params"]["network"] == model.config["params"]["network"]  # rlchain's own file inside
    np.testing.assert_array_equal(loaded.predict(obs)[0], model.predict(obs)[0])


def test_a_user_extractor_model_saves_to_zip_and_loads_with_its_class(tmp_path):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", seed=0, policy_kwargs={"features_extractor_class": Doubler},
                        **quiet(tmp_path))
    path = model.save(str(tmp_path / "custom"))
    assert {"data", "policy.pth", MEMBER} <= set(zipfile.ZipFile(path).namelist())
    loaded = rlchain.PPO.load(str(tmp_path / "custom"))
    assert isinstance(loaded.policy.features_extractor, Doubler)
    obs = np.stack([gym.make("CartPole-v1").reset(seed=s)[0] for s in range(5)])
    np.testing.assert_array_equal(loaded.predict(obs)[0], model.predict(obs)[0])


def test_model_attributes_sb3_pages_read(tmp_path, capsys):
    model = rlchain.PPO("MlpPolicy", "CartPole-v1", learning_rate=1e-3, gamma=0.98, **quiet(tmp_path))
    assert model.learning_rate == 1e-3 and model.gamma == 0.98
    assert model.observation_space.shape == (4,) and model.action_space.n == 2
    assert model.env.num_envs == 1  # SB3's VecEnv
    actions, values, log_prob = model.policy(torch.zeros(2, 4), deterministic=True)
    assert actions.shape == (2,) and values.shape == (2, 1) and log_prob.shape == (2,)
    path = model.save(str(tmp_path / "m"))
    rlchain.PPO.load(path, print_system_info=True)
    out = capsys.readouterr().out
    assert "== CURRENT SYSTEM INFO ==" in out and "PyTorch: " in out


def test_sac_actor_exports_as_the_export_guide_does(tmp_path):
    onnxruntime = pytest.importorskip("onnxruntime")
    model = rlchain.SAC("MlpPolicy", "Pendulum-v1", seed=0, **quiet(tmp_path))

    class OnnxablePolicy(nn.Module):
        def __init__(self, actor):
            super().__init__()
            self.actor = actor

        def forward(self, observation):
            return self.actor(observation, deterministic=True)

    onnxable = OnnxablePolicy(model.policy.actor)
    dummy = torch.randn(1, 3)
    torch.onnx.export(onnxable, dummy, str(tmp_path / "actor.onnx"), opset_version=17, input_names=["input"],
                      dynamo=False)
    obs = np.zeros((1, 3), np.float32)
    got = onnxruntime.InferenceSession(str(tmp_path / "actor.onnx")).run(None, {"input": obs})[0]
    with torch.no_grad():
        want = model.actor(torch.as_tensor(obs), deterministic=True).numpy()
    np.testing.assert_allclose(got, want, atol=1e-6)
    assert np.all(np.abs(want) <= 1.0)  # before rescaling to the bounds, as SB3's actor
    traced = torch.jit.trace(onnxable.eval(), dummy)  # the guide's TorchScript path (its trace check included)
    np.testing.assert_allclose(traced(torch.as_tensor(obs)).detach().numpy(), want, atol=1e-6)
