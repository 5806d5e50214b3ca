"""rlchain.SAC with ``policy_kwargs=dict(share_features_extractor=True)`` (SB3 accepts it for SAC; its default is
False): it trains with the extractor updated by the actor's loss only, resumes bit-identically, loads back
with the critic still reading the actor's extractor, and its actor exports to ONNX."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

import rlchain

pytestmark = pytest.mark.smoke


class Extractor(nn.Module):  # any nn.Module with features_dim is an SB3 features extractor here
    def __init__(self, observation_space, features_dim=8):
        super().__init__()
        self.features_dim = features_dim
        self.net = nn.Sequential(nn.Linear(observation_space.shape[0], features_dim), nn.Tanh())

    def forward(self, observations):
        return self.net(observations)


class OnnxableActor(nn.Module):
    def __init__(self, actor):
        super().__init__()
        self.actor = actor

    def forward(self, observation):
        return self.actor(observation, deterministic=True)


KWARGS = {"policy_kwargs": {"features_extractor_class": Extractor, "share_features_extractor": True,
                            "net_arch": [16]},
          "learning_starts": 16, "batch_size": 8, "buffer_size": 500, "seed": 0, "verbose": 0,
          "num_steps_per_episode": 16, "save_replay_buffer": True}  # rlchain's keys: 16-frame epochs, the buffer
                                                                    # in the checkpoint (an exact resume)


def make(tmp_path):
    return rlchain.SAC("MlpPolicy", "Pendulum-v1", tensorboard_log=str(tmp_path / "runs"), **KWARGS)


def network(model):
    return model.policy.net.network


def test_shared_extractor_trains_by_the_actor_resumes_and_loads(tmp_path):
    model = make(tmp_path)
    before = {k: v.clone() for k, v in network(model).actor.encoder.state_dict().items()}
    model.learn(64)
    net = network(model)
    assert net.critic.encoder is net.actor.encoder
    after = net.actor.encoder.state_dict()
    assert any(not torch.equal(before[k], after[k]) for k in before)  # the actor's loss trained it
    target = model.policy.net.critic_target.encoder
    assert target is not net.actor.encoder  # the target critic has its own, Polyak-averaged copy
    assert any(not torch.equal(target.state_dict()[k], after[k]) for k in after)

    resumed = make(tmp_path).learn(32)
    resumed.learn(32, reset_num_timesteps=False)
    a, b = model.policy.state_dict(), resumed.policy.state_dict()
    assert resumed.num_timesteps == 64 and a.keys() == b.keys()
    assert all(torch.equal(a[k], b[k]) for k in a)

    loaded = rlchain.SAC.load(model.save(str(tmp_path / "shared")))
    assert network(loaded).critic.encoder is network(loaded).actor.encoder
    obs = np.stack([gym.make("Pendulum-v1").reset(seed=s)[0] for s in range(3)]).astype(np.float32)
    np.testing.assert_array_equal(loaded.predict(obs, deterministic=True)[0],
                                  model.predict(obs, deterministic=True)[0])

    onnxruntime = pytest.importorskip("onnxruntime")
    onnx_path = str(tmp_path / "actor.onnx")  # SB3's export guide: the actor, deterministic
    torch.onnx.export(OnnxableActor(loaded.policy.actor), torch.zeros(1, 3), onnx_path, opset_version=17,
                      input_names=["input"], dynamo=False)
    got = onnxruntime.InferenceSession(onnx_path).run(None, {"input": obs[:1]})[0]
    with torch.no_grad():
        want = loaded.actor(torch.as_tensor(obs[:1]), deterministic=True).numpy()
    np.testing.assert_allclose(got, want, atol=1e-5)
