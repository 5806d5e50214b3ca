"""resnet_actor_critic (networks/resnet_actor_critic.py, networks/impala.py): shapes, uint8 images,
RNN states, the previous reward / action inputs, config errors and ONNX export."""

import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.config.errors import ConfigError
from rlchain.config.fields import parse_dataclass
from rlchain.config.load import parse_params
from rlchain.config.network import ResnetCnnConfig, ResnetNetworkConfig
from rlchain.envs.wrappers.dict_obs import FlatDictBox
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import Categorical
from rlchain.networks.impala import ImpalaEncoder
from rlchain.networks.resnet_actor_critic import resnet_actor_critic_network

IMAGE = (4, 84, 84)
ACTIONS = 6


def config(**overrides):
    block = {"name": "resnet_actor_critic", "space": {"discrete": None},
             "cnn": {"permute_input": False, "conv_depths": [16, 32, 32]},
             "mlp": {"units": [512], "activation": "relu"}, **overrides}
    return parse_dataclass(ResnetNetworkConfig, block, "params.network", "t.yaml")


def dict_space(image=IMAGE, actions=ACTIONS):
    """The flat layout envs/wrappers/reward_action_obs.py produces."""
    return FlatDictBox(gym.spaces.Dict({"last_action": gym.spaces.Discrete(actions),
                                        "observation": gym.spaces.Box(0, 1, image, np.float32),
                                        "reward": gym.spaces.Box(-1, 1, (), np.float32)}))


def build(cfg, space, action_space=None):
    torch.manual_seed(0)
    action_space = action_space or gym.spaces.Discrete(ACTIONS)
    actions = int(np.prod(action_space.shape)) if isinstance(action_space, gym.spaces.Box) else ACTIONS
    return resnet_actor_critic_network(cfg, action_space=action_space, actions_num=actions, input_shape=space.shape,
                                       observation_space=space, value_size=1)


def flat_obs(batch, reward, action, seed=0):
    """(B, flat) observations: the same random image, the given reward and action in every row."""
    rng = np.random.default_rng(seed)
    image = rng.random((1, int(np.prod(IMAGE))), dtype=np.float32).repeat(batch, 0)
    onehot = np.eye(ACTIONS, dtype=np.float32)[np.full(batch, action)]
    return torch.from_numpy(np.concatenate([onehot, image, np.full((batch, 1), reward, np.float32)], 1))


def test_impala_encoder_matches_rl_games_sizes_and_permutes():
    enc = ImpalaEncoder(ResnetCnnConfig(permute_input=False), IMAGE)
    assert enc.out_size == 32 * 11 * 11  # 84 -> 42 -> 21 -> 11 (max-pool 3x3 / 2, padding 1)
    assert enc(torch.rand(3, *IMAGE)).shape == (3, 3872)
    last = ImpalaEncoder(ResnetCnnConfig(permute_input=True), (84, 84, 4))
    last.load_state_dict(enc.state_dict())
    x = torch.rand(2, *IMAGE)
    assert torch.allclose(last(x.permute(0, 2, 3, 1)), enc(x), atol=1e-6)
    assert (enc(x) >= 0).all()  # the activation after flattening


def test_activations_as_rl_games_places_them():
    """cnn.activation inside the residual blocks, mlp.activation on the flattened features."""
    net = build(config(cnn={"permute_input": False, "conv_depths": [4], "activation": "tanh"},
                       mlp={"units": [8], "activation": "elu"}), gym.spaces.Box(0, 1, (2, 8, 8), np.float32))
    encoder = net.cnn
    assert isinstance(encoder.out_act, torch.nn.ELU)
    assert isinstance(encoder.stages[0].res_block1.activate1, torch.nn.Tanh)


def test_impala_encoder_rejects_non_images():
    with pytest.raises(ValueError, match=r"params\.network\.cnn: resnet_actor_critic needs image observations"):
        ImpalaEncoder(ResnetCnnConfig(), (28231,))


def test_parameter_count_is_rl_games_pong_resnet():
    """rl_games' atari/ppo_pong_envpool_resnet.yaml network has 2,878,167 parameters (A2CResnetBuilder)."""
    net = build(config(require_rewards=True, require_last_actions=True,
                       rnn={"name": "lstm", "units": 256, "layers": 1}), dict_space())
    assert sum(p.numel() for p in net.parameters()) == 2_878_167
    assert net.rnn.rnn.input_size == 512 + 1 + ACTIONS  # mlp out + reward + one-hot action


def test_image_observations_discrete_shapes():
    space = gym.spaces.Box(0, 255, IMAGE, np.uint8)
    net = build(config(), space)
    logits, value, states = net({"obs": torch.rand(5, *IMAGE)})
    assert logits.shape == (5, ACTIONS) and value.shape == (5, 1) and states is None
    assert not net.is_rnn()


def test_uint8_images_are_scaled_once_by_the_model():
    space = gym.spaces.Box(0, 255, IMAGE, np.uint8)
    model = ActorCritic(build(config(), space), Categorical(ACTIONS), IMAGE, 1, False, False)
    raw = torch.randint(0, 256, (3, *IMAGE), dtype=torch.uint8)
    params, value, _ = model.evaluate(raw)
    expected, _, _ = model.a2c_network({"obs": raw.float() / 255.0})
    assert torch.allclose(params, expected, atol=1e-6)


def test_rnn_states_shapes_and_sequences():
    cfg = config(require_rewards=True, require_last_actions=True, rnn={"name": "lstm", "units": 32, "layers": 2})
    net = build(cfg, dict_space())
    states = net.get_default_rnn_state(4)
    assert [tuple(s.shape) for s in states] == [(2, 4, 32), (2, 4, 32)]
    obs = flat_obs(4 * 3, 0.5, 2)  # 4 sequences of 3 steps
    logits, value, new = net({"obs": obs, "rnn_states": states, "seq_length": 3,
                              "dones": torch.zeros(12, dtype=torch.bool)})
    assert logits.shape == (12, ACTIONS) and value.shape == (12, 1)
    assert [tuple(s.shape) for s in new] == [(2, 4, 32), (2, 4, 32)]
    gru = build(config(rnn={"name": "gru", "units": 8}, separate=True), dict_space())
    assert [tuple(s.shape) for s in gru.get_default_rnn_state(3)] == [(1, 3, 8), (1, 3, 8)]  # actor, critic


@pytest.mark.parametrize("rnn", [{"name": "lstm", "units": 16}, {"name": "gru", "units": 16, "before_mlp": True},
                                 None])
def test_reward_and_last_action_change_the_output(rnn):
    net = build(config(require_rewards=True, require_last_actions=True, rnn=rnn, mlp={"units": [32]}),
                dict_space())
    states = net.get_default_rnn_state(2)

    def run(reward, action):
        with torch.no_grad():
            return net({"obs": flat_obs(2, reward, action), "rnn_states": states})[:2]

    base = run(0.0, 0)
    for other in (run(1.0, 0), run(0.0, 3)):
        assert not torch.allclose(base[0], other[0]) and not torch.allclose(base[1], other[1])


def test_dict_observations_without_the_flags_read_only_the_image():
    net = build(config(), dict_space())
    with torch.no_grad():
        a, b = net({"obs": flat_obs(2, 0.0, 0)}), net({"obs": flat_obs(2, 1.0, 4)})
    assert torch.equal(a[0], b[0]) and torch.equal(a[1], b[1])
    assert net.mlp.in_size == 3872


def test_only_the_requested_input_is_read():
    net = build(config(require_last_actions=True, rnn={"name": "lstm", "units": 8}), dict_space())
    assert net.rnn.rnn.input_size == 512 + ACTIONS
    states = net.get_default_rnn_state(2)
    with torch.no_grad():
        a = net({"obs": flat_obs(2, 0.0, 1), "rnn_states": states})
        b = net({"obs": flat_obs(2, -1.0, 1), "rnn_states": states})
    assert torch.equal(a[0], b[0])  # the reward is not an input


def test_continuous_head():
    net = build(config(space={"continuous": {"fixed_sigma": True}}), gym.spaces.Box(0, 1, IMAGE, np.float32),
                gym.spaces.Box(-1, 1, (3,), np.float32))
    mu, sigma, value, _ = net({"obs": torch.rand(2, *IMAGE)})
    assert mu.shape == sigma.shape == (2, 3) and value.shape == (2, 1)


@pytest.mark.parametrize("flag", ["require_rewards", "require_last_actions"])
def test_inputs_without_a_dict_obs_env_are_a_one_line_error(flag):
    with pytest.raises(ValueError) as err:
        build(config(**{flag: True}), gym.spaces.Box(0, 255, IMAGE, np.uint8))
    message = str(err.value)
    assert message.startswith(f"params.network.{flag}: needs the previous") and "\n" not in message
    assert "use_dict_obs_space" in message and "wrap_impala" in message and "(4, 84, 84)" in message


def test_config_keys(base_config):
    base_config["params"]["network"] = {"name": "resnet_actor_critic", "space": {"discrete": None},
                                        "cnn": {"conv_depths": [8, 16], "regularizer": {"name": "None"}},
                                        "require_rewards": True, "rnn": {"name": "lstm", "units": 8}}
    base_config["params"]["config"].update(seq_length=3)
    with pytest.raises(ConfigError, match=r"params\.config\.seq_length: horizon_length 8 is not divisible"):
        parse_params(base_config, "t.yaml")  # the RNN sequence checks apply to this network too
    base_config["params"]["config"].update(seq_length=4)
    parsed = parse_params(base_config, "t.yaml").network
    assert isinstance(parsed, ResnetNetworkConfig) and parsed.cnn.conv_depths == [8, 16] and parsed.require_rewards
    base_config["params"]["network"]["cnn"]["conv_depth"] = [1]
    with pytest.raises(ConfigError, match=r"params\.network\.cnn\.conv_depth: unknown key; did you mean 'conv_depths'"):
        parse_params(base_config, "t.yaml")
    del base_config["params"]["network"]["cnn"]["conv_depth"]
    base_config["params"]["network"]["cnn"]["conv_depths"] = []
    with pytest.raises(ConfigError, match=r"params\.network\.cnn\.conv_depths: needs at least one depth"):
        parse_params(base_config, "t.yaml")


def test_require_rewards_on_another_network_names_the_network(base_config):
    base_config["params"]["network"]["require_rewards"] = True
    with pytest.raises(ConfigError, match=r"params\.network\.require_rewards: only network resnet_actor_critic "
                                          r"reads it .* this network is 'actor_critic'"):
        parse_params(base_config, "t.yaml")
    base_config["params"]["network"]["require_rewards"] = False  # off: accepted and dropped
    parse_params(base_config, "t.yaml")


def test_onnx_export_of_dict_observations_and_lstm(tmp_path):
    pytest.importorskip("onnxruntime")
    from rlchain.inference.export.onnx import export_model_onnx, onnx_session, random_observations, verify_onnx

    image = (4, 20, 20)
    space = dict_space(image)
    cfg = config(require_rewards=True, require_last_actions=True, rnn={"name": "lstm", "units": 8},
                 cnn={"permute_input": False, "conv_depths": [4, 8]}, mlp={"units": [16]})
    model = ActorCritic(build(cfg, space), Categorical(ACTIONS), space.shape, 1, False, True).eval()
    path = export_model_onnx(model, space.shape, os.path.join(tmp_path, "resnet.onnx"))
    session = onnx_session(path)
    assert session.get_inputs()[0].shape[1:] == [ACTIONS + 4 * 20 * 20 + 1]
    assert verify_onnx(model, path, random_observations(space, 6), session, steps=3) < 1e-4
