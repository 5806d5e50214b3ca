"""SB3 users' own classes on rlchain's loop, as SB3's custom_policy and export guides write them (the classes
subclass Stable-Baselines3's own bases, only the algorithm imported from rlchain): a features extractor and an
ActorCriticPolicy subclass train, resume bit-identically, save and load, and export to ONNX with the PyTorch
policy's outputs; CnnPolicy (NatureCNN) and a custom Dict extractor train with PPO, SAC and DQN."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

import rlchain

sb3 = pytest.importorskip("stable_baselines3")
from stable_baselines3.common.policies import ActorCriticPolicy  # noqa: E402
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor  # noqa: E402

from tests.smoke.sb3_image_envs import SideImage  # noqa: E402

pytestmark = pytest.mark.smoke


class CustomExtractor(BaseFeaturesExtractor):
    def __init__(self, observation_space, features_dim=16):
        super().__init__(observation_space, features_dim)
        self.net = nn.Sequential(nn.Linear(observation_space.shape[0], features_dim), nn.ReLU())

    def forward(self, observations):
        return self.net(observations)


class CustomNetwork(nn.Module):
    def __init__(self, feature_dim, last_layer_dim_pi=32, last_layer_dim_vf=16):
        super().__init__()
        self.latent_dim_pi, self.latent_dim_vf = last_layer_dim_pi, last_layer_dim_vf
        self.policy_net = nn.Sequential(nn.Linear(feature_dim, last_layer_dim_pi), nn.ReLU())
        self.value_net = nn.Sequential(nn.Linear(feature_dim, last_layer_dim_vf), nn.ReLU())

    def forward(self, features):
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features):
        return self.policy_net(features)

    def forward_critic(self, features):
        return self.value_net(features)


class CustomActorCriticPolicy(ActorCriticPolicy):
    def __init__(self, observation_space, action_space, lr_schedule, *args, **kwargs):
        kwargs["ortho_init"] = False
        super().__init__(observation_space, action_space, lr_schedule, *args, **kwargs)

    def _build_mlp_extractor(self):
        self.mlp_extractor = CustomNetwork(self.features_dim)


class CustomCombined(BaseFeaturesExtractor):
    def __init__(self, observation_space):
        super().__init__(observation_space, features_dim=1)
        extractors, total = {}, 0
        for key, subspace in observation_space.spaces.items():
            if key == "img":
                extractors[key] = nn.Sequential(nn.MaxPool2d(6), nn.Flatten())
                total += subspace.shape[0] * (subspace.shape[1] // 6) * (subspace.shape[2] // 6)
            else:
                extractors[key] = nn.Flatten()
                total += gym.spaces.flatdim(subspace)
        self.extractors = nn.ModuleDict(extractors)
        self._features_dim = total

    def forward(self, observations):
        return torch.cat([e(observations[k]) for k, e in self.extractors.items()], dim=1)


class OnnxableSB3Policy(nn.Module):  # SB3's export guide
    def __init__(self, policy):
        super().__init__()
        self.policy = policy

    def forward(self, observation):
        return self.policy(observation, deterministic=True)


def make(tmp_path, policy, env, seed=0, **kwargs):
    return rlchain.PPO(policy, env, n_steps=32, batch_size=16, seed=seed, verbose=0,
                       tensorboard_log=str(tmp_path / "runs"), **kwargs)


EXTRACTOR = {"features_extractor_class": CustomExtractor, "features_extractor_kwargs": {"features_dim": 8},
             "net_arch": {"pi": [16], "vf": [8]}, "share_features_extractor": False}


@pytest.mark.parametrize(("policy", "policy_kwargs", "env_id"), [("MlpPolicy", EXTRACTOR, "CartPole-v1"),
                                                                 (CustomActorCriticPolicy, None, "Pendulum-v1")])
def test_user_class_trains_resumes_bit_identically_loads_and_exports(tmp_path, policy, policy_kwargs, env_id):
    onnxruntime = pytest.importorskip("onnxruntime")
    straight = make(tmp_path, policy, env_id, policy_kwargs=policy_kwargs).learn(128)
    resumed = make(tmp_path, policy, env_id, policy_kwargs=policy_kwargs).learn(64)
    resumed.learn(64, reset_num_timesteps=False)
    a, b = straight.policy.state_dict(), resumed.policy.state_dict()
    assert resumed.num_timesteps == 128 and a.keys() == b.keys()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert any(k.startswith("mlp_extractor.") for k in a)  # SB3's own parameter names
    path = straight.save(str(tmp_path / "model.pth"))
    loaded = rlchain.PPO.load(path)
    obs = np.stack([gym.make(env_id).reset(seed=s)[0] for s in range(4)]).astype(np.float32)
    np.testing.assert_array_equal(loaded.predict(obs)[0], straight.predict(obs)[0])
    onnx_path = str(tmp_path / "policy.onnx")
    torch.onnx.export(OnnxableSB3Policy(loaded.policy), torch.randn(1, *loaded.observation_space.shape), onnx_path,
                      opset_version=17, input_names=["input"], dynamo=False)
    one = obs[:1]  # the guide's batch of one
    actions, values, log_prob = onnxruntime.InferenceSession(onnx_path).run(None, {"input": one})
    with torch.no_grad():
        want = loaded.policy(torch.as_tensor(one), deterministic=True)
    np.testing.assert_allclose(actions, want[0].numpy(), atol=1e-5)
    np.testing.assert_allclose(values, want[1].numpy(), atol=1e-5)
    np.testing.assert_allclose(log_prob, want[2].numpy(), atol=1e-4)
    exported = straight.export_onnx(str(tmp_path / "rlchain.onnx"))  # rlchain's own exporter checks parity itself
    assert exported.endswith("rlchain.onnx")


def test_user_policy_class_is_found_again_by_name_when_loaded(tmp_path):
    model = make(tmp_path, CustomActorCriticPolicy, "CartPole-v1")
    path = model.save(str(tmp_path / "custom.pth"))
    loaded = rlchain.PPO.load(path)
    assert isinstance(loaded.policy.mlp_extractor, CustomNetwork)  # SB3's attribute, from the user's class


@pytest.mark.parametrize("algo", ["PPO", "DQN", "SAC"])
def test_cnn_policy_on_channel_last_images(tmp_path, algo):
    env = SideImage(continuous=algo == "SAC")
    kwargs = {"n_steps": 32, "batch_size": 16} if algo == "PPO" else \
        {"learning_starts": 16, "batch_size": 8, "buffer_size": 200}
    model = getattr(rlchain, algo)("CnnPolicy", env, seed=0, verbose=0, tensorboard_log=str(tmp_path / "runs"),
                                   **kwargs).learn(64)
    assert model.num_timesteps >= 64 and model.config["params"]["network"]["name"] == "sb3_policy"
    action, _ = model.predict(env.reset(seed=0)[0])
    assert env.action_space.contains(action.astype(env.action_space.dtype) if algo == "SAC" else int(action))


@pytest.mark.parametrize("algo", ["PPO", "SAC"])
def test_custom_combined_extractor_on_dict_observations(tmp_path, algo):
    env = SideImage(dict_obs=True, continuous=algo == "SAC")
    kwargs = {"n_steps": 32, "batch_size": 16} if algo == "PPO" else \
        {"learning_starts": 16, "batch_size": 8, "buffer_size": 200}
    policy_kwargs = {"features_extractor_class": CustomCombined}
    if algo == "SAC":
        policy_kwargs["net_arch"] = {"pi": [16], "qf": [32, 32]}
    model = getattr(rlchain, algo)("MultiInputPolicy", env, policy_kwargs=policy_kwargs, seed=0, verbose=0,
                                   tensorboard_log=str(tmp_path / "runs"), **kwargs).learn(64)
    action, _ = model.predict(env.reset(seed=0)[0])
    assert np.shape(action) == env.action_space.shape
    if algo == "SAC":  # SB3's model.actor / model.policy.actor: actions in [-1, 1]
        assert model.policy.actor.model is model.policy.net
