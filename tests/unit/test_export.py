"""ONNX export: onnxruntime parity with PyTorch, the shipped checkpoint, and clear errors."""

import os
import shutil
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch

pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from rlchain import Runner  # noqa: E402
from rlchain.config.network import DiscreteSpaceConfig, MlpConfig, NetworkConfig, SpaceConfig  # noqa: E402
from rlchain.inference.export.onnx import (  # noqa: E402
    env_observations,
    export_from_cli,
    export_model_onnx,
    export_onnx,
    obs_dtype,
    random_observations,
    verify_onnx,
)
from rlchain.models.actor_critic import ActorCritic  # noqa: E402
from rlchain.models.build import build_env, build_model  # noqa: E402
from rlchain.models.distributions import Categorical  # noqa: E402
from rlchain.networks.actor_critic import ActorCriticBuilder  # noqa: E402
from rlchain.runs import checkpoint as ckpt  # noqa: E402
from tests.conftest import CONFIGS, ROOT  # noqa: E402

TOL = 1e-5
CARTPOLE_CKPT = os.path.join(ROOT, "nn", "cartpole.pth")


def built(config, overrides=(), num_envs=4):
    params = Runner().load(os.path.join(CONFIGS, config), list(overrides)).params
    env = build_env(params, num_envs, 0)
    torch.manual_seed(0)
    return params, env, build_model(params, env, torch.device("cpu")).eval()


def run_onnx(path, obs):
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    return session.run(["action", "value"], {"obs": obs})


def torch_reference(model, obs):
    """The Player's deterministic action (act + to_env) and model.value(): independent of OnnxPolicy."""
    obs_t = torch.as_tensor(obs)
    actions = model.dist.to_env(model.act(obs_t, deterministic=True)["actions"])
    return actions.numpy(), model.value(obs_t).numpy()


def test_discrete_cartpole_parity(tmp_path):
    _, env, model = built("ppo_cartpole.yaml")
    path = export_model_onnx(model, env.observation_space.shape, str(tmp_path / "cp.onnx"))
    rand = random_observations(env.observation_space, 64)
    real = env_observations(model, env, 16)
    env.close()
    assert real.shape == (4 * 17, 4)
    for obs in (rand, real):
        assert verify_onnx(model, path, obs) <= TOL
        action, value = run_onnx(path, obs)
        want_action, want_value = torch_reference(model, obs)
        assert action.dtype == np.int64 and action.shape == (len(obs),)
        assert np.array_equal(action, want_action)
        assert value.shape == (len(obs), 1) and np.abs(value - want_value).max() <= TOL
    # dynamic batch axis: 1 and an odd size
    for n in (1, 37):
        action, value = run_onnx(path, rand[:n])
        assert action.shape == (n,) and value.shape == (n, 1)


def test_continuous_pendulum_normalized_parity(tmp_path):
    _, env, model = built("ppo_pendulum.yaml", ["params.config.normalize_input=True",
                                                "params.config.normalize_value=True"])
    assert model.running_mean_std is not None and model.value_mean_std is not None
    # non-trivial statistics and weights: normalization must really be inside the graph
    gen = torch.Generator().manual_seed(1)
    model.update_normalizers(obs=torch.randn(500, 3, generator=gen) * torch.tensor([0.5, 0.3, 4.0])
                             + torch.tensor([0.4, -0.1, 1.5]),
                             returns=torch.randn(500, 1, generator=gen) * 5.0 - 10.0)
    with torch.no_grad():
        model.a2c_network.mu.weight.mul_(3.0)  # means on both sides of 1: clipped and unclipped actions
        model.a2c_network.mu.bias.fill_(0.8)
        model.a2c_network.sigma.fill_(-0.5)
    assert model.running_mean_std.running_mean.abs().max() > 0.3 and model.value_mean_std.running_var.item() > 10
    path = export_model_onnx(model, env.observation_space.shape, str(tmp_path / "pendulum.onnx"))
    rand = random_observations(env.observation_space, 64)
    real = env_observations(model, env, 16)
    env.close()
    low, high = env.action_space.low, env.action_space.high
    for obs in (rand, real):
        assert verify_onnx(model, path, obs) <= TOL
        action, value = run_onnx(path, obs)
        want_action, want_value = torch_reference(model, obs)
        assert action.dtype == np.float32 and action.shape == (len(obs), 1)
        assert np.abs(action - want_action).max() <= TOL
        assert np.abs(value - want_value).max() <= TOL
        assert (action >= low - 1e-6).all() and (action <= high + 1e-6).all()
    action, _ = run_onnx(path, rand)
    assert np.isclose(action, 2.0).any()  # clipped to the bound, rescaled to [-2, 2]
    assert (np.abs(action) < 1.99).any()
    # the statistics matter: the same weights without them give other outputs
    plain = ActorCritic(model.a2c_network, model.dist, (3,), 1, normalize_input=False, normalize_value=False)
    assert np.abs(torch_reference(plain, rand)[1] - run_onnx(path, rand)[1]).max() > 1e-2


def test_uint8_observations_are_scaled_in_graph(tmp_path):
    space = gym.spaces.Box(0, 255, (2, 3, 3), np.uint8)
    builder = ActorCriticBuilder()
    cfg = NetworkConfig(mlp=MlpConfig(units=[8]), space=SpaceConfig(discrete=DiscreteSpaceConfig()))
    builder.load(cfg)
    net = builder.build("n", action_space=gym.spaces.Discrete(3), input_shape=space.shape, actions_num=3,
                        value_size=1)
    model = ActorCritic(net, Categorical(3), space.shape, 1, normalize_input=True, normalize_value=False)
    model.update_normalizers(obs=torch.rand(64, *space.shape) * 0.5)
    assert obs_dtype(space) == torch.uint8
    path = export_model_onnx(model, space.shape, str(tmp_path / "img.onnx"), input_dtype=torch.uint8)
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    assert session.get_inputs()[0].type == "tensor(uint8)"
    obs = random_observations(space, 32)
    assert obs.dtype == np.uint8
    assert verify_onnx(model, path, obs) <= TOL
    assert np.array_equal(session.run(["action"], {"obs": obs})[0], torch_reference(model, obs)[0])


def test_export_shipped_cartpole_checkpoint(tmp_path, capsys):
    params = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml")).params
    path = export_onnx(params, CARTPOLE_CKPT, str(tmp_path / "out" / "cartpole.onnx"))
    assert os.path.isfile(path)
    # the exported greedy policy plays CartPole as well as the checkpoint does
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    env = gym.make("CartPole-v1")
    obs, _ = env.reset(seed=3)
    total, done = 0.0, False
    while not done:
        action = session.run(["action"], {"obs": obs[None].astype(np.float32)})[0]
        obs, reward, terminated, truncated, _ = env.step(int(action[0]))
        total += reward
        done = terminated or truncated
    env.close()
    assert total >= 400

    # the CLI entry: default output next to the checkpoint, path and parity printed
    local = tmp_path / "cartpole.pth"
    shutil.copy(CARTPOLE_CKPT, local)
    out = export_from_cli(Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml")), str(local), None)
    assert out == str(tmp_path / "cartpole.onnx") and os.path.isfile(out)
    printed = capsys.readouterr().out
    assert out in printed and "max abs diff" in printed and "64 random observations" in printed
    diffs = [float(w) for w in printed.replace(",", " ").split() if w[:1].isdigit() and "e" in w]
    assert len(diffs) == 2 and max(diffs) <= TOL


def test_bad_checkpoint_is_the_play_error(tmp_path):
    params = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml")).params
    missing = str(tmp_path / "nope.pth")
    with pytest.raises(ckpt.CheckpointError) as play_err:
        Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml")).play(missing, games=1, quiet=True)
    with pytest.raises(ckpt.CheckpointError) as export_err:
        export_onnx(params, missing, str(tmp_path / "x.onnx"))
    assert str(export_err.value) == str(play_err.value) == f"{missing}: checkpoint not found"
    garbage = tmp_path / "garbage.pth"
    garbage.write_bytes(b"not a checkpoint")
    with pytest.raises(ckpt.CheckpointError, match="not a readable checkpoint"):
        export_onnx(params, str(garbage), str(tmp_path / "x.onnx"))
    # a checkpoint of another network: the shape mismatch is named
    wide = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml"), ["params.network.mlp.units=[32]"]).params
    with pytest.raises(ckpt.CheckpointError, match="does not match|has shape"):
        export_onnx(wide, CARTPOLE_CKPT, str(tmp_path / "x.onnx"))
    assert not os.path.exists(tmp_path / "x.onnx")


def test_missing_onnxruntime_names_the_extra(tmp_path, monkeypatch):
    params = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml")).params
    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # import raises ImportError
    with pytest.raises(ImportError, match=r"pip install rlchain\[onnx\]"):
        export_onnx(params, CARTPOLE_CKPT, str(tmp_path / "x.onnx"))
