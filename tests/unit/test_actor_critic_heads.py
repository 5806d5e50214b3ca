"""``network.head`` of the built-in actor_critic network (networks/actor_critic.py): each output stream's own
hidden layers after the trunk (and its rnn), with their own activation, as RLlib's ``head_fcnet_hiddens`` builds
its policy and value heads; a bad block is one line naming the file and the key."""

import gymnasium as gym
import pytest
import torch
import torch.nn as nn

from rlchain.config.errors import ConfigError
from rlchain.config.fields import parse_dataclass
from rlchain.config.load import parse_params
from rlchain.config.network import NetworkConfig
from rlchain.networks.actor_critic import ActorCriticBuilder, ActorCriticNetwork
from rlchain.rllib import networks
from rlchain.rllib.algorithms.ppo import PPOConfig

FIXED = {"continuous": {"mu_activation": "None", "sigma_activation": "None", "mu_init": {"name": "default"},
                        "sigma_init": {"name": "const_initializer", "val": 0.0}, "fixed_sigma": True}}


def _network(block, obs=8, actions=3, space=None):
    builder = ActorCriticBuilder()
    builder.load(parse_dataclass(NetworkConfig, block, "params.network", "cfg.yaml"))
    return builder.build("network", input_shape=(obs,), actions_num=actions, value_size=1,
                         action_space=space or gym.spaces.Box(-1, 1, (actions,)))


def test_separate_trunks_then_a_linear_head_per_stream_are_rllibs_mujoco_module():
    # RLlib 2.60's module for mujoco_ppo.py's model config (fcnet [256, 256] tanh, head [256] with no activation,
    # vf_share_layers=False, free_log_std) on Humanoid (376 -> 17): its parameters' shapes, printed from RLlib
    rllib = [(256, 376), (256,), (256, 256), (256,)] * 2 + [(17,), (256, 256), (256,), (17, 256), (17,),
                                                            (256, 256), (256,), (1, 256), (1,)]
    net = _network({"separate": True, "space": FIXED, "mlp": {"units": [256, 256], "activation": "tanh"},
                    "head": {"units": [256], "activation": "None"}}, obs=376, actions=17)
    assert sorted(tuple(p.shape) for p in net.parameters()) == sorted(rllib)
    assert [isinstance(m, nn.Linear) for m in net.actor_head] == [True, False]  # no activation between the linears
    assert isinstance(net.actor_head[1], nn.Identity)
    mu, sigma, value, _ = net({"obs": torch.zeros(5, 376)})
    assert mu.shape == sigma.shape == (5, 17) and value.shape == (5, 1)


def test_a_shared_trunk_still_gives_each_stream_its_own_head():
    net = _network({"space": {"discrete": {}}, "mlp": {"units": [16], "activation": "tanh"},
                    "head": {"units": [8], "activation": "relu"}}, space=gym.spaces.Discrete(3))
    assert net.actor_head is not net.critic_head and net.actor_mlp[0].out_features == 16
    with torch.no_grad():
        net.critic_head[0].weight.zero_()
        net.critic_head[0].bias.fill_(1.0)
        logits, value, _ = net({"obs": torch.ones(2, 8)})
    assert logits.shape == (2, 3)
    # the value sees only its own head: ones through relu -> value.weight.sum() + bias
    assert torch.allclose(value, (net.value.weight.sum() + net.value.bias).expand(2, 1))


def test_the_heads_follow_the_lstm():
    net = _network({"space": {"discrete": {}}, "mlp": {"units": [16], "activation": "tanh"},
                    "rnn": {"name": "lstm", "units": 12, "layers": 1},
                    "head": {"units": [6], "activation": "relu"}}, actions=2, space=gym.spaces.Discrete(2))
    assert net.actor_head[0].in_features == 12 and net.logits.in_features == 6 and net.value.in_features == 6
    states = net.get_default_rnn_state(3)
    logits, value, new_states = net({"obs": torch.zeros(3, 8), "rnn_states": states})
    assert logits.shape == (3, 2) and value.shape == (3, 1) and len(new_states) == 2


def test_a_central_value_network_builds_only_the_value_head():
    cfg = parse_dataclass(NetworkConfig, {"mlp": {"units": [8]}, "head": {"units": [4]}}, "params.network", "x.yaml")
    net = ActorCriticNetwork(cfg, (5,), 0, 1, False, central_value=True)
    assert not hasattr(net, "actor_head") and net.value.in_features == 4
    value, _ = net({"obs": torch.zeros(2, 5)})
    assert value.shape == (2, 1)


def _params(head):
    return {"params": {"algo": {"name": "a2c_continuous"}, "model": {"name": "continuous_a2c_logstd"},
            "network": {"name": "actor_critic", "space": FIXED, "mlp": {"units": [8]}, "head": head},
            "config": {"env_name": "Pendulum-v1", "num_actors": 1, "horizon_length": 8, "minibatch_size": 8}}}


@pytest.mark.parametrize("head, key", [({"units": [0]}, "params.network.head.units"),
                                       ({"units": [8], "activation": "tahn"}, "params.network.head.activation"),
                                       ([8], "params.network.head")])
def test_a_bad_head_block_is_one_line_naming_the_file_and_key(head, key):
    with pytest.raises(ConfigError) as info:
        parse_params(_params(head), "cfg.yaml")
    message = str(info.value)
    assert message.startswith(f"cfg.yaml: {key}") and "\n" not in message


def test_a_good_head_block_parses():
    params = parse_params(_params({"units": [8, 4], "activation": "None"}), "cfg.yaml")
    assert params.network.head.units == [8, 4] and params.network.head.activation == "None"


def test_the_rllib_faces_shared_lstm_block_builds_rllibs_parameters():
    # RLlib 2.60's module for vf_share_layers, fcnet [32], head [16], an LSTM of 24 on CartPole (printed from
    # RLlib): one encoder (tokenizer, LSTM), then the pi and vf heads each with their own layer of 16
    rllib = [(32, 4), (32,), (96, 32), (96, 24), (96,), (96,), (16, 24), (16,), (2, 16), (2,), (16, 24), (16,),
             (1, 16), (1,)]
    config = PPOConfig().rl_module(model_config={"vf_share_layers": True, "fcnet_hiddens": [32],
                                                 "head_fcnet_hiddens": [16], "use_lstm": True, "lstm_cell_size": 24})
    block, _ = networks.actor_critic_network(config, gym.spaces.Box(-1, 1, (4,)), False)
    net = _network(block, obs=4, actions=2, space=gym.spaces.Discrete(2))
    assert sorted(tuple(p.shape) for p in net.parameters()) == sorted(rllib)
