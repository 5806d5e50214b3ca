"""rlchain's actor-critic network (networks/actor_critic.py) carries rl_games' layout: the same state dict keys,
shapes and parameter order as the rl_games face's ``A2CBuilder.Network`` (rl_games' own module layout) for the
same block, so a checkpoint crosses between them with no renaming."""

import gymnasium as gym
import pytest
import torch

from rlchain.config.fields import parse_dataclass
from rlchain.config.network import NetworkConfig
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import Categorical
from rlchain.networks.actor_critic import ActorCriticBuilder
from rlchain.rl_games.algos_torch import network_builder

MLP = {"units": [16, 8], "activation": "elu", "initializer": {"name": "default"}}
FIXED = {"continuous": {"mu_activation": "None", "sigma_activation": "None", "mu_init": {"name": "default"},
                        "sigma_init": {"name": "const_initializer", "val": 0.0}, "fixed_sigma": True}}
CNN = {"type": "conv2d", "activation": "relu", "initializer": {"name": "default"},
       "convs": [{"filters": 4, "kernel_size": 3, "strides": 1, "padding": 0}]}
BLOCKS = {
    "continuous_fixed_sigma": ({"space": FIXED, "mlp": MLP}, (5,), gym.spaces.Box(-1, 1, (3,))),
    "separate_lstm_layer_norm": ({"space": {"discrete": {}}, "mlp": MLP, "separate": True,
                                  "rnn": {"name": "lstm", "units": 6, "layers": 1, "layer_norm": True}},
                                 (5,), gym.spaces.Discrete(3)),
    "gru_before_mlp": ({"space": {"discrete": {}}, "mlp": MLP,
                        "rnn": {"name": "gru", "units": 6, "layers": 1, "before_mlp": True}},
                       (5,), gym.spaces.Discrete(3)),
    "cnn": ({"space": {"discrete": {}}, "mlp": MLP, "cnn": CNN}, (6, 6, 2), gym.spaces.Discrete(3)),
    "multi_discrete": ({"space": {"multi_discrete": {}}, "mlp": MLP}, (5,), gym.spaces.MultiDiscrete([3, 2])),
}


def _face(block, shape, space):
    sizes = list(space.nvec) if isinstance(space, gym.spaces.MultiDiscrete) else None
    actions = sizes if sizes else (space.n if isinstance(space, gym.spaces.Discrete) else space.shape[0])
    face = network_builder.A2CBuilder()
    face.load({"name": "actor_critic", **block})
    return face.build("a2c", actions_num=[int(n) for n in sizes] if sizes else actions, input_shape=shape,
                      value_size=1, num_seqs=4)


def _ours(block, shape, space):
    sizes = list(space.nvec) if isinstance(space, gym.spaces.MultiDiscrete) else None
    actions = sum(sizes) if sizes else (space.n if isinstance(space, gym.spaces.Discrete) else space.shape[0])
    ours = ActorCriticBuilder()
    ours.load(parse_dataclass(NetworkConfig, block, "params.network", "cfg.yaml"))
    return ours.build("network", input_shape=shape, actions_num=actions, value_size=1, action_space=space)


def _both(block, shape, space):
    theirs = _face(block, shape, space)
    return _ours(block, shape, space), theirs


@pytest.mark.parametrize("kind", list(BLOCKS))
def test_state_dict_and_parameter_order_are_rl_games(kind):
    ours, theirs = _both(*BLOCKS[kind])
    assert {k: tuple(v.shape) for k, v in ours.state_dict().items()} == \
        {k: tuple(v.shape) for k, v in theirs.state_dict().items()}
    assert [name for name, _ in ours.named_parameters()] == [name for name, _ in theirs.named_parameters()]


def test_rl_games_face_weights_give_the_same_outputs_in_rlchain():
    ours, theirs = _both(*BLOCKS["separate_lstm_layer_norm"])
    ours.load_state_dict(theirs.state_dict())  # no renaming
    obs, states = torch.randn(4, 5), tuple(theirs.get_default_rnn_state())
    logits, value, _ = theirs({"obs": obs, "rnn_states": states})
    mine, my_value, _ = ours({"obs": obs, "rnn_states": states})
    assert torch.allclose(mine, logits, atol=1e-6) and torch.allclose(my_value, value, atol=1e-6)


def test_the_model_holds_rl_games_model_names():
    ours, _ = _both(*BLOCKS["continuous_fixed_sigma"])
    model = ActorCritic(ours, Categorical(3), (5,), 1, normalize_input=True, normalize_value=True)
    assert list(model.state_dict())[:6] == ["value_mean_std.running_mean", "value_mean_std.running_var",
                                            "value_mean_std.count", "running_mean_std.running_mean",
                                            "running_mean_std.running_var", "running_mean_std.count"]
    assert list(model.state_dict())[6:8] == ["a2c_network.sigma", "a2c_network.actor_mlp.0.weight"]


@pytest.mark.parametrize("kind", list(BLOCKS))
def test_one_network_the_face_draws_the_same_weights(kind):
    """A2CBuilder.Network is the actor-critic network: with one seed both builds hold the same tensors and,
    on the same observations, give the same outputs (channels-last images permuted by either)."""
    torch.manual_seed(0)
    ours = _ours(*BLOCKS[kind])
    torch.manual_seed(0)
    theirs = _face(*BLOCKS[kind])
    assert all(torch.equal(a, b) for a, b in zip(ours.state_dict().values(), theirs.state_dict().values()))
    obs = torch.rand(4, *BLOCKS[kind][1])
    inputs = {"obs": obs, "rnn_states": ours.get_default_rnn_state(4)} if ours.is_rnn() else {"obs": obs}
    for a, b in zip(ours(dict(inputs))[:-1], theirs(dict(inputs))[:-1]):
        for x, y in zip(a if isinstance(a, list) else [a], b if isinstance(b, list) else [b]):
            assert torch.equal(x, y)
