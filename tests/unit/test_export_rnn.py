"""ONNX export of recurrent (LSTM/GRU) policies: states in and out, parity with PyTorch over steps."""

import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.config.fields import parse_dataclass
from rlchain.config.network import NetworkConfig
from rlchain.inference.export.onnx import OnnxPolicy, export_model_onnx, onnx_session, random_observations, verify_onnx
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import Categorical, DiagGaussian
from rlchain.networks.actor_critic import ActorCriticNetwork

pytest.importorskip("onnxruntime")


def _model(rnn, continuous, separate=False):
    space = {"continuous": {"fixed_sigma": True}} if continuous else {"discrete": None}
    cfg = parse_dataclass(NetworkConfig, {"separate": separate, "space": space, "mlp": {"units": [16]},
                                          "rnn": rnn}, "params.network", "t")
    torch.manual_seed(0)
    net = ActorCriticNetwork(cfg, (4,), 2, 1, continuous=continuous)
    dist = (DiagGaussian(gym.spaces.Box(-1, 1, (2,)), sigma_is_logstd=True, clip_actions=True) if continuous
            else Categorical(2))
    return ActorCritic(net, dist, (4,), 1, normalize_input=True, normalize_value=True).eval()


@pytest.mark.parametrize("rnn,separate,continuous", [
    ({"name": "lstm", "units": 8}, False, False),
    ({"name": "gru", "units": 8, "layers": 2}, True, True),
    ({"name": "lstm", "units": 8, "before_mlp": True, "layer_norm": True}, False, True),
])
def test_rnn_policy_exports_with_state_inputs_and_outputs(tmp_path, rnn, separate, continuous):
    model = _model(rnn, continuous, separate)
    path = export_model_onnx(model, (4,), os.path.join(tmp_path, "policy.onnx"))
    session = onnx_session(path)
    policy = OnnxPolicy(model)
    expected_states = (2 if rnn["name"] == "lstm" else 1) * (2 if separate else 1)
    assert [i.name for i in session.get_inputs()] == ["obs", *[f"rnn_state_{k}" for k in range(expected_states)]]
    assert [o.name for o in session.get_outputs()][:2] == ["action", "value"]
    obs = random_observations(gym.spaces.Box(-2, 2, (4,)), 5)
    assert verify_onnx(model, path, obs, session, steps=4) < 1e-4
    # the states matter: a second step from the first step's states differs from a fresh start
    zero = [s.numpy() for s in policy.initial_state(5)]
    first = session.run(None, {"obs": obs.astype(np.float32), **dict(zip(policy.state_names, zero))})
    second = session.run(None, {"obs": obs.astype(np.float32), **dict(zip(policy.state_names, first[2:]))})
    assert not np.allclose(first[1], second[1])
