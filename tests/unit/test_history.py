"""The history layer: a causal transformer over a window of past steps, carried like an RNN state. Stepping
it one step at a time gives what a training sequence computes; episode starts cut the window; its config
keys reject wrong values."""

import copy

import pytest
import torch

from rlchain.config import ConfigError, parse_params
from rlchain.config.network import HistoryConfig
from rlchain.networks.history import HistoryLayer
from tests.conftest import BASE


def _layer(length=4):
    torch.manual_seed(0)
    return HistoryLayer(3, HistoryConfig(length=length, layers=2, heads=2, dim=8)).eval()


def test_step_by_step_equals_the_training_sequence_across_an_episode_start():
    layer = _layer()
    batch, steps = 2, 7
    x = torch.randn(batch, steps, 3)
    resets = torch.zeros(batch, steps, dtype=torch.bool)
    resets[1, 4] = True  # env 1's episode restarts at step 4
    with torch.no_grad():
        seq_out, seq_states = layer(x.reshape(-1, 3), layer.initial_state(batch, torch.device("cpu")),
                                    resets.reshape(-1), steps)
        states, outs = layer.initial_state(batch, torch.device("cpu")), []
        for t in range(steps):
            keep = (~resets[:, t]).float().view(1, batch, 1)
            states = tuple(s * keep for s in states)  # the collector zeroes the state where an episode ended
            out, states = layer(x[:, t], states, None, 1)
            outs.append(out)
    stepped = torch.stack(outs, 1).reshape(-1, 8)
    assert torch.allclose(seq_out, stepped, atol=1e-5)
    assert all(torch.allclose(a, b, atol=1e-6) for a, b in zip(seq_states, states))


def test_the_window_is_what_the_output_depends_on():
    layer = _layer(length=3)
    x = torch.randn(1, 6, 3)
    with torch.no_grad():
        out, _ = layer(x.reshape(-1, 3), layer.initial_state(1, torch.device("cpu")), None, 6)
        changed = x.clone()
        changed[0, 0] += 5.0  # step 0 is outside the window of steps 3.. (length 3: steps t-2 .. t)
        out2, _ = layer(changed.reshape(-1, 3), layer.initial_state(1, torch.device("cpu")), None, 6)
    assert not torch.allclose(out[:3], out2[:3])
    assert torch.allclose(out[3:], out2[3:], atol=1e-6)


def test_an_episode_start_hides_the_earlier_steps():
    layer = _layer()
    x = torch.randn(1, 5, 3)
    resets = torch.tensor([False, False, False, True, False])
    with torch.no_grad():
        out, _ = layer(x.reshape(-1, 3), layer.initial_state(1, torch.device("cpu")), resets, 5)
        fresh, _ = layer(x[0, 3:], layer.initial_state(1, torch.device("cpu")), None, 2)
    assert torch.allclose(out[3:], fresh, atol=1e-5)


def _network(**history):
    raw = copy.deepcopy(BASE)
    raw["params"]["network"]["history"] = history
    raw["params"]["config"].update({"seq_length": 4})
    return raw


@pytest.mark.parametrize("key, value", [("length", 1), ("layers", 0), ("heads", 0), ("dim", -2), ("width", 4)])
def test_wrong_history_values_name_the_key(key, value):
    with pytest.raises(ConfigError) as err:
        parse_params(_network(**{key: value}), "cfg.yaml")
    assert f"params.network.history.{key}" in str(err.value) and "\n" not in str(err.value)


def test_history_with_rnn_or_dim_not_dividing_by_heads_is_an_error():
    raw = _network(length=4)
    raw["params"]["network"]["rnn"] = {"name": "lstm", "units": 8}
    with pytest.raises(ConfigError, match="params.network.history: choose rnn or history"):
        parse_params(raw, "cfg.yaml")
    with pytest.raises(ValueError, match="params.network.history.dim: 6 must divide by heads"):
        HistoryLayer(3, HistoryConfig(dim=6, heads=4))


def test_onnx_export_takes_the_window_and_matches_torch_over_an_episode(tmp_path):
    pytest.importorskip("onnxruntime")
    import numpy as np

    from rlchain import Runner
    from rlchain.inference.export.onnx import OnnxPolicy, export_model_onnx, onnx_session
    from rlchain.models.build import build_env, build_model
    from tests.conftest import CONFIGS

    params = Runner().load(f"{CONFIGS}/ppo_cartpole_masked_velocity_history.yaml").params
    env = build_env(params, 1, 0)
    torch.manual_seed(0)
    model = build_model(params, env, torch.device("cpu")).eval()
    model.update_normalizers(obs=torch.randn(64, *env.observation_space.shape))
    path = export_model_onnx(model, env.observation_space.shape, str(tmp_path / "history.onnx"))
    session = onnx_session(path)
    policy = OnnxPolicy(model)
    assert [i.name for i in session.get_inputs()] == ["obs", "rnn_state_0", "rnn_state_1"]
    window = session.get_inputs()[1].shape
    assert window[0] == 7 and window[2] == 32  # the last length - 1 steps' tokens
    obs, states, onnx_states, diff, steps = env.reset(), policy.initial_state(1), None, 0.0, 0
    onnx_states = [s.numpy() for s in states]
    done = False
    while not done and steps < 500:
        with torch.no_grad():
            action, value, *states = policy(torch.as_tensor(obs, dtype=torch.float32), *states)
        got = session.run(None, {"obs": np.asarray(obs, np.float32), "rnn_state_0": onnx_states[0],
                                 "rnn_state_1": onnx_states[1]})
        for a, b in zip(got, (action, value, *states)):
            diff = max(diff, float(np.abs(a.astype(np.float64) - b.numpy().astype(np.float64)).max()))
        onnx_states = got[2:]
        result = env.step(action.numpy())
        obs, done, steps = result.obs, bool(result.terminated[0] or result.truncated[0]), steps + 1
    env.close()
    assert steps >= 8 and diff < 1e-5, (steps, diff)  # past the window's length: the window slides
