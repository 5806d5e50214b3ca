"""The act step's direct pass through a plain MLP actor-critic (rlchain/networks/direct.py): the network's own
output bit for bit, declined under hooks, refused for networks that are not plain."""

import copy

import gymnasium as gym
import pytest
import torch

from rlchain.config.network import (
    ContinuousSpaceConfig,
    DiscreteSpaceConfig,
    MlpConfig,
    NetworkConfig,
    RnnConfig,
    SpaceConfig,
)
from rlchain.networks.actor_critic import ActorCriticBuilder
from rlchain.networks.direct import DirectPass


def _network(space: gym.Space, **cfg):
    builder = ActorCriticBuilder()
    spaces = SpaceConfig(continuous=ContinuousSpaceConfig(fixed_sigma=cfg.pop("fixed_sigma", True)),
                         discrete=DiscreteSpaceConfig())
    builder.load(NetworkConfig(space=spaces, **cfg))
    actions = space.shape[0] if isinstance(space, gym.spaces.Box) else int(space.n)
    torch.manual_seed(0)
    return builder.build("n", action_space=space, input_shape=(5,), actions_num=actions, value_size=2)


PLAIN = [
    (gym.spaces.Discrete(3), {"mlp": MlpConfig(units=[16, 8], activation="elu")}),
    (gym.spaces.Discrete(2), {"mlp": MlpConfig(units=[32], activation="None")}),
    (gym.spaces.Discrete(4), {"mlp": MlpConfig(units=[8], activation="tanh"), "separate": True}),
    (gym.spaces.Box(-1, 1, (3,)), {"mlp": MlpConfig(units=[8, 8], activation="relu")}),
    (gym.spaces.Box(-1, 1, (2,)), {"mlp": MlpConfig(units=[8]), "fixed_sigma": False, "separate": True}),
]


@pytest.mark.parametrize("space,cfg", PLAIN)
def test_direct_pass_is_the_networks_output_bit_for_bit(space, cfg):
    net = _network(space, **cfg)
    direct = DirectPass(net)
    assert direct.plain
    obs = torch.randn(7, 5)
    with torch.inference_mode():
        want, got = net({"obs": obs}), direct(obs)
    assert len(got) == len(want) and got[-1] is None and want[-1] is None
    for a, b in zip(got[:-1], want[:-1]):
        assert a.shape == b.shape and torch.equal(a, b)


def test_direct_pass_declines_under_hooks_and_replaced_modules():
    net = _network(gym.spaces.Discrete(2), mlp=MlpConfig(units=[8]))
    direct = DirectPass(net)
    obs = torch.randn(3, 5)
    handle = net.logits.register_forward_hook(lambda module, args, out: out * 2)
    assert direct(obs) is None
    handle.remove()
    assert direct(obs) is not None
    handle = torch.nn.modules.module.register_module_forward_pre_hook(lambda module, args: None)
    try:
        assert direct(obs) is None
    finally:
        handle.remove()
    net.logits = torch.nn.Linear(8, 2)
    assert direct(obs) is None


def test_direct_pass_refuses_networks_that_are_not_plain():
    discrete = gym.spaces.Discrete(2)
    assert not DirectPass(_network(discrete, mlp=MlpConfig(units=[8], normalization="layer_norm"))).plain
    assert not DirectPass(_network(discrete, mlp=MlpConfig(units=[8], d2rl=True))).plain
    assert not DirectPass(_network(discrete, mlp=MlpConfig(units=[8]), rnn=RnnConfig(units=8))).plain
    assert not DirectPass(torch.nn.Linear(5, 2)).plain
    # per-stream hidden layers between the trunk and the heads (network.head): the act step runs the module's call
    assert not DirectPass(_network(discrete, mlp=MlpConfig(units=[8]), head=MlpConfig(units=[8]))).plain


def test_deep_copied_model_acts_with_its_own_layers():
    from rlchain.models.actor_critic import ActorCritic
    from rlchain.models.distributions import Categorical

    net = _network(gym.spaces.Discrete(2), mlp=MlpConfig(units=[8]))
    model = ActorCritic(net, Categorical(2), (5,), 2, normalize_input=False, normalize_value=False)
    obs = torch.randn(4, 5)
    model.act(obs)  # makes the model's direct pass
    clone = copy.deepcopy(model)
    with torch.no_grad():
        clone.a2c_network.logits.weight.add_(1.0)
        want = clone.evaluate(obs)[0]
    got = clone.act(obs, deterministic=True)
    assert torch.equal(got["params"], want)
    assert not torch.equal(got["params"], model.act(obs, deterministic=True)["params"])
