"""ConvEncoder (networks/cnn.py), the cnn block through the config, and uint8 image observations."""

import copy
import dataclasses

import gymnasium as gym
import pytest
import torch

from rlchain.config.load import parse_params
from rlchain.config.network import CnnConfig, ConvSpec, DiscreteSpaceConfig, NetworkConfig, SpaceConfig
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from rlchain.networks.actor_critic import ActorCriticBuilder
from rlchain.networks.cnn import ConvEncoder

NATURE = [ConvSpec(filters=32, kernel_size=8, strides=4), ConvSpec(filters=64, kernel_size=4, strides=2),
          ConvSpec(filters=64, kernel_size=3, strides=1)]
"""The DQN-Nature convolutions of rl_games' Atari configs."""


def encoder(shape, permute=False, convs=NATURE, kind="conv2d", activation="elu", initializer=None):
    cfg = CnnConfig(type=kind, permute_input=permute, activation=activation, convs=convs)
    if initializer is not None:
        cfg = dataclasses.replace(cfg, initializer=initializer)
    return ConvEncoder(cfg, shape)


def test_conv2d_nature_output_size_and_shape():
    enc = encoder((4, 84, 84))
    assert enc.out_size == 64 * 7 * 7  # 84 -> 20 -> 9 -> 7
    assert enc(torch.rand(3, 4, 84, 84)).shape == (3, 3136)


def test_conv2d_padding_and_strides_follow_the_formula():
    enc = encoder((3, 10, 12), convs=[ConvSpec(filters=5, kernel_size=3, strides=2, padding=1)])
    assert enc.out_size == 5 * 5 * 6  # (10 + 2 - 3) // 2 + 1 = 5, (12 + 2 - 3) // 2 + 1 = 6
    assert enc(torch.zeros(2, 3, 10, 12)).shape == (2, 150)


def test_permute_input_takes_channels_last_and_matches_channels_first():
    first = encoder((4, 84, 84), permute=False)
    last = encoder((84, 84, 4), permute=True)
    last.load_state_dict(first.state_dict())
    x = torch.rand(2, 4, 84, 84)
    assert last.out_size == first.out_size == 3136
    assert torch.allclose(last(x.permute(0, 2, 3, 1)), first(x), atol=1e-6)


def test_conv1d_shapes_and_permute():
    convs = [ConvSpec(filters=8, kernel_size=3), ConvSpec(filters=4, kernel_size=5, strides=2)]
    enc = encoder((3, 32), convs=convs, kind="conv1d")
    assert enc.out_size == 4 * 13  # 32 -> 30 -> (30 - 5) // 2 + 1 = 13
    assert enc(torch.zeros(5, 3, 32)).shape == (5, 52)
    permuted = encoder((32, 3), permute=True, convs=convs, kind="conv1d")
    permuted.load_state_dict(enc.state_dict())
    x = torch.rand(2, 3, 32)
    assert torch.allclose(permuted(x.transpose(1, 2)), enc(x), atol=1e-6)


def test_convs_that_shrink_the_input_to_nothing_are_a_clear_error():
    with pytest.raises(ValueError, match=r"cnn\.convs\[1\]: the convolutions shrink the input \(4, 12, 12\)"):
        encoder((4, 12, 12))  # 12 -> 2 after the 8x8 / 4 conv; the 4x4 conv does not fit
    with pytest.raises(ValueError, match=r"cnn\.convs\[0\]"):
        encoder((8, 4), convs=[ConvSpec(filters=2, kernel_size=5)], kind="conv1d")


@pytest.mark.parametrize("kind,shape", [("conv2d", (8,)), ("conv2d", (4, 84)), ("conv1d", (4, 8, 8))])
def test_obs_dims_must_match_the_conv_type(kind, shape):
    with pytest.raises(ValueError, match=rf"cnn\.type: {kind} needs observations of \d dims.*{shape}"):
        encoder(shape, kind=kind)


def test_initializer_and_activation_are_applied():
    from rlchain.config.network import InitializerConfig

    enc = encoder((1, 16, 16), convs=[ConvSpec(filters=2, kernel_size=3)], activation="relu",
                  initializer=InitializerConfig(name="const_initializer", val=0.5))
    conv = enc[0]
    assert torch.all(conv.weight == 0.5) and torch.all(conv.bias == 0)
    assert isinstance(enc[1], torch.nn.ReLU)


def _pong_like_model(normalize_input):
    cfg = NetworkConfig(cnn=CnnConfig(permute_input=False, activation="elu", convs=NATURE),
                        space=SpaceConfig(discrete=DiscreteSpaceConfig()))
    builder = ActorCriticBuilder()
    builder.load(cfg)
    space = gym.spaces.Discrete(6)
    net = builder.build("n", action_space=space, input_shape=(4, 84, 84), actions_num=6, value_size=1)
    return ActorCritic(net, make_distribution("discrete_a2c", space, False), (4, 84, 84), 1,
                       normalize_input=normalize_input, normalize_value=False)


def test_uint8_images_are_scaled_once_and_the_normalizer_sees_the_same_scale():
    model = _pong_like_model(normalize_input=True)
    obs = torch.randint(0, 256, (64, 4, 84, 84), dtype=torch.uint8)
    model.update_normalizers(obs=obs)
    mean = model.running_mean_std.running_mean
    assert 0.3 < float(mean.mean()) < 0.7  # the [0, 1] scale, not 0..255
    normalized = model.preprocess(obs)
    assert normalized.dtype == torch.float32
    assert abs(float(normalized.mean())) < 0.05 and 0.9 < float(normalized.std()) < 1.1
    params, value = model(obs)
    assert params.shape == (64, 6) and value.shape == (64, 1)


def test_uint8_input_equals_float_input_divided_by_255():
    model = _pong_like_model(normalize_input=False).eval()
    obs = torch.randint(0, 256, (3, 4, 84, 84), dtype=torch.uint8)
    with torch.no_grad():
        a, _ = model(obs)
        b, _ = model(obs.float() / 255.0)
    assert torch.allclose(a, b, atol=1e-6)


def test_cnn_block_from_an_rl_games_config_builds():
    raw = {"params": {
        "algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "separate": False, "space": {"discrete": None},
                    "cnn": {"permute_input": False, "type": "conv2d", "activation": "elu",
                            "initializer": {"name": "default"},
                            "convs": [{"filters": 32, "kernel_size": 8, "strides": 4, "padding": 0},
                                      {"filters": 64, "kernel_size": 4, "strides": 2, "padding": 0}]},
                    "mlp": {"units": [512], "activation": "elu"}},
        "config": {"name": "x", "env_name": "CartPole-v1", "minibatch_size": 64}}}
    params = parse_params(copy.deepcopy(raw))
    cnn = params.network.cnn
    assert cnn.type == "conv2d" and not cnn.permute_input and [c.filters for c in cnn.convs] == [32, 64]
    assert ConvEncoder(cnn, (4, 84, 84)).out_size == 64 * 9 * 9
    raw["params"]["network"]["cnn"]["type"] = "conv3d"
    with pytest.raises(ValueError, match=r"params\.network\.cnn\.type"):
        parse_params(raw)
