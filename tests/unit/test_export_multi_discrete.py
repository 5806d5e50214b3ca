"""ONNX export of multi-discrete policies: the graph's action is the per-dimension argmax."""

import os

import numpy as np
import pytest
import torch

pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from rlchain import Runner  # noqa: E402
from rlchain.inference.export.onnx import export_model_onnx, random_observations, verify_onnx  # noqa: E402
from rlchain.models.build import build_env, build_model  # noqa: E402
from tests.conftest import CONFIGS  # noqa: E402


@pytest.mark.parametrize("overrides", [
    [],                                                      # MultiDiscrete([3, 5]): unequal sizes
    ["params.config.env_config.tuple_actions=True"],          # Tuple(Discrete(3), Discrete(5))
])
def test_multi_discrete_onnx_parity(tmp_path, overrides):
    params = Runner().load(os.path.join(CONFIGS, "ppo_test_multidiscrete.yaml"), overrides).params
    env = build_env(params, 2, 0)
    torch.manual_seed(0)
    model = build_model(params, env, torch.device("cpu")).eval()
    with torch.no_grad():  # sharpen the logits so that every dimension's argmax varies with the obs
        logits = model.a2c_network.logits  # one Linear per action dimension for multi-discrete actions
        for head in logits if isinstance(logits, torch.nn.ModuleList) else [logits]:
            head.weight.mul_(20.0)
    path = export_model_onnx(model, env.observation_space.shape, str(tmp_path / "md.onnx"))
    obs = random_observations(env.observation_space, 256)
    action, _ = ort.InferenceSession(path, providers=["CPUExecutionProvider"]).run(["action", "value"], {"obs": obs})
    params_t, _ = model(torch.as_tensor(obs))
    want = torch.stack([chunk.argmax(-1) for chunk in params_t.split([3, 5], -1)], -1).numpy()
    assert action.shape == (256, 2) and action.dtype == np.int64
    np.testing.assert_array_equal(action, want)
    assert len(np.unique(action[:, 1])) > 1  # the comparison is not trivially constant
    assert verify_onnx(model, path, obs) < 1e-5
    env.close()


def test_equal_sizes_multi_discrete_onnx_parity(tmp_path):
    import gymnasium as gym

    from rlchain.config.network import MlpConfig, MultiDiscreteSpaceConfig, NetworkConfig, SpaceConfig
    from rlchain.models.actor_critic import ActorCritic
    from rlchain.models.distributions import make_distribution
    from rlchain.networks.actor_critic import ActorCriticBuilder

    space = gym.spaces.MultiDiscrete([3, 3, 3])
    builder = ActorCriticBuilder()
    builder.load(NetworkConfig(space=SpaceConfig(multi_discrete=MultiDiscreteSpaceConfig()), mlp=MlpConfig(units=[16])))
    torch.manual_seed(0)
    net = builder.build("n", action_space=space, actions_num=9, input_shape=(4,), value_size=1)
    model = ActorCritic(net, make_distribution("multi_discrete_a2c", space, True), (4,), 1, False, False).eval()
    path = export_model_onnx(model, (4,), str(tmp_path / "eq.onnx"))
    obs = np.random.default_rng(0).normal(size=(64, 4)).astype(np.float32) * 5
    action, _ = ort.InferenceSession(path, providers=["CPUExecutionProvider"]).run(["action", "value"], {"obs": obs})
    want = model(torch.as_tensor(obs))[0].reshape(64, 3, 3).argmax(-1).numpy()
    np.testing.assert_array_equal(action, want)
