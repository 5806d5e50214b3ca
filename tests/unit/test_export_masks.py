"""ONNX export of ``use_action_masks`` policies: the ``action_mask`` input, masked argmax, parity."""

import os

import gymnasium as gym
import numpy as np
import pytest
import torch

pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from rlchain import Runner  # noqa: E402
from rlchain.config.fields import parse_dataclass  # noqa: E402
from rlchain.config.network import NetworkConfig  # noqa: E402
from rlchain.inference.export.onnx import (  # noqa: E402
    OnnxPolicy,
    env_rollout,
    export_from_cli,
    export_model_onnx,
    random_masks,
    random_observations,
    verify_onnx,
)
from rlchain.models.actor_critic import ActorCritic  # noqa: E402
from rlchain.models.build import build_env, build_model  # noqa: E402
from rlchain.models.distributions import Categorical  # noqa: E402
from rlchain.networks.actor_critic import ActorCriticNetwork  # noqa: E402
from rlchain.runs import checkpoint as ckpt  # noqa: E402
from tests.conftest import CONFIGS  # noqa: E402

CONFIG = os.path.join(CONFIGS, "ppo_test_masked.yaml")
DISCRETE = ["params.model.name=discrete_a2c", "params.network.space={discrete: null}",
            "params.config.env_config.multi_discrete=False"]
CASES = {"discrete": (DISCRETE, [6]), "multi_discrete": ([], [4, 3])}


def masked_model(overrides=(), use_masks=True):
    """The shipped masked config's model (random weights, sharpened logits) and its env."""
    params = Runner().load(CONFIG, [*overrides, f"params.config.use_action_masks={use_masks}"]).params
    env = build_env(params, 2, 0)
    torch.manual_seed(0)
    model = build_model(params, env, torch.device("cpu")).eval()
    with torch.no_grad():  # sharpen the logits so that the argmax varies with the observation
        logits = model.a2c_network.logits  # one Linear per action dimension for multi-discrete actions
        for head in logits if isinstance(logits, torch.nn.ModuleList) else [logits]:
            head.weight.mul_(20.0)
    return params, env, model


def split(flat, nvec):
    """(B, sum(nvec)) -> per-dimension chunks."""
    return np.split(flat, np.cumsum(nvec)[:-1], axis=1)


def masks_forbidding_argmax(logits, nvec, seed=0):
    """Random masks in which every dimension's unmasked argmax (the largest logit) is forbidden."""
    rng = np.random.default_rng(seed)
    parts = []
    for chunk in split(logits, nvec):
        n = chunk.shape[1]
        best = chunk.argmax(1)
        part = rng.random(chunk.shape) < 0.5
        part[np.arange(len(chunk)), (best + 1 + rng.integers(n - 1, size=len(chunk))) % n] = True
        part[np.arange(len(chunk)), best] = False
        parts.append(part)
    return np.concatenate(parts, axis=1)


@pytest.mark.parametrize("case", sorted(CASES))
def test_masked_policy_never_picks_a_masked_out_action(tmp_path, case):
    overrides, nvec = CASES[case]
    _, env, model = masked_model(overrides)
    path = export_model_onnx(model, env.observation_space.shape, str(tmp_path / "masked.onnx"))
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    inputs = session.get_inputs()
    assert [i.name for i in inputs] == ["obs", OnnxPolicy.mask_name] == ["obs", "action_mask"]
    assert inputs[1].type == "tensor(bool)" and inputs[1].shape == ["batch", sum(nvec)]

    obs = random_observations(env.observation_space, 256)
    env.close()
    with torch.no_grad():
        logits = model(torch.as_tensor(obs))[0].numpy()
    masks = masks_forbidding_argmax(logits, nvec)
    action = session.run(["action"], {"obs": obs, "action_mask": masks})[0]
    action = action.reshape(len(obs), len(nvec))
    for k, (chunk_mask, chunk_logits) in enumerate(zip(split(masks, nvec), split(logits, nvec))):
        assert chunk_mask[np.arange(len(obs)), action[:, k]].all()  # always an allowed action
        assert (action[:, k] != chunk_logits.argmax(1)).all()  # never the (forbidden) largest logit
        # the best allowed one: the argmax of the logits restricted to the mask
        np.testing.assert_array_equal(action[:, k], np.where(chunk_mask, chunk_logits, -np.inf).argmax(1))
    # the Player's masked action (model.act with action_masks), independent of OnnxPolicy
    want = model.act(torch.as_tensor(obs), deterministic=True, action_masks=torch.as_tensor(masks))["actions"]
    np.testing.assert_array_equal(action, want.numpy().reshape(action.shape))
    # all allowed: the unmasked argmax
    free = session.run(["action"], {"obs": obs, "action_mask": np.ones_like(masks)})[0].reshape(len(obs), -1)
    np.testing.assert_array_equal(free, np.stack([c.argmax(1) for c in split(logits, nvec)], 1))
    # parity with random masks (the default) and with these
    assert verify_onnx(model, path, obs, session) < 1e-5
    assert verify_onnx(model, path, obs, session, masks=masks) < 1e-5


def test_policy_without_masks_keeps_its_graph_inputs(tmp_path):
    _, env, model = masked_model(DISCRETE, use_masks=False)
    assert model.dist.mask_size == 6 and not model.use_action_masks  # masks possible, not used
    path = export_model_onnx(model, env.observation_space.shape, str(tmp_path / "plain.onnx"))
    env.close()
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    assert [(i.name, i.type) for i in session.get_inputs()] == [("obs", "tensor(float)")]
    assert [o.name for o in session.get_outputs()] == ["action", "value"]
    assert OnnxPolicy(model).input_names == ["obs"]
    obs = random_observations(gym.spaces.Box(0.0, 1.0, (6,)), 32)
    assert verify_onnx(model, path, obs, session) < 1e-5


def test_recurrent_masked_policy_takes_the_mask_after_the_states(tmp_path):
    cfg = parse_dataclass(NetworkConfig, {"space": {"discrete": None}, "mlp": {"units": [16]},
                                          "rnn": {"name": "lstm", "units": 8}}, "params.network", "t")
    torch.manual_seed(0)
    net = ActorCriticNetwork(cfg, (4,), 5, 1, continuous=False)
    model = ActorCritic(net, Categorical(5), (4,), 1, False, False, use_action_masks=True).eval()
    path = export_model_onnx(model, (4,), str(tmp_path / "rnn_masked.onnx"))
    session = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    assert [i.name for i in session.get_inputs()] == ["obs", "rnn_state_0", "rnn_state_1", "action_mask"]
    assert OnnxPolicy(model).input_names == [i.name for i in session.get_inputs()]
    obs = random_observations(gym.spaces.Box(-2, 2, (4,)), 16)
    assert verify_onnx(model, path, obs, session, steps=4) < 1e-4
    states = [s.numpy() for s in OnnxPolicy(model).initial_state(16)]
    only = np.zeros((16, 5), dtype=bool)
    only[np.arange(16), np.arange(16) % 5] = True  # exactly one allowed action per row
    action = session.run(["action"], {"obs": obs, "rnn_state_0": states[0], "rnn_state_1": states[1],
                                      "action_mask": only})[0]
    np.testing.assert_array_equal(action, np.arange(16) % 5)


def test_random_masks_keep_an_allowed_action_per_dimension():
    from rlchain.models.distributions import MultiCategorical

    for dist, nvec in ((Categorical(2), [2]), (MultiCategorical([4, 1, 3]), [4, 1, 3])):
        masks = random_masks(dist, 500, seed=3)
        assert masks.shape == (500, sum(nvec)) and masks.dtype == np.bool_
        assert all(part.any(1).all() for part in split(masks, nvec))
        assert not masks.all()  # something is masked out


def test_cli_parity_feeds_the_env_masks(tmp_path, capsys):
    params, env, model = masked_model()
    obs, masks = env_rollout(model, env, 5)
    env.close()
    assert obs.shape == (2 * 6, 7) and masks.shape == (2 * 6, 7) and masks.dtype == np.bool_
    checkpoint = str(tmp_path / "masked.pth")
    ckpt.save_atomic({"format": ckpt.FORMAT, "model": model.state_dict()}, checkpoint)
    out = export_from_cli(Runner().load(CONFIG), checkpoint, str(tmp_path / "m.onnx"))
    printed = capsys.readouterr().out
    assert os.path.isfile(out) and "parity (with action masks)" in printed
    diffs = [float(w) for w in printed.replace(",", " ").split() if w[:1].isdigit() and "e" in w]
    assert len(diffs) == 2 and max(diffs) <= 1e-5
