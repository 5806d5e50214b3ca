"""rl_games' network-building contract: A2CBuilder.Network's layout, forward tuples and states, BaseNetwork's
helpers, the recurrent layer's episode restarts, RunningMeanStd, the model classes and the registries."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
import torch
import torch.nn as nn

from rlchain.models.distributions import MultiCategorical
from rlchain.networks.actor_critic import ActorCriticNetwork
from rlchain.networks.base import instantiate
from rlchain.networks.rnn import RecurrentLayer
from rlchain.registry import NETWORKS
from rlchain.rl_games.algos_torch import model_builder, models, network_builder
from rlchain.rl_games.algos_torch.running_mean_std import RunningMeanStd
from rlchain.rl_games.common.layers.recurrent import GRUWithDones, LSTMWithDones

MLP = {"units": [16, 8], "activation": "elu", "initializer": {"name": "default"}}
CONTINUOUS = {"continuous": {"mu_activation": "None", "sigma_activation": "None", "mu_init": {"name": "default"},
                             "sigma_init": {"name": "const_initializer", "val": 0.5}, "fixed_sigma": False}}


def build(params, **kwargs):
    builder = network_builder.A2CBuilder()
    builder.load(params)
    return builder.build("a2c", **{"actions_num": 3, "input_shape": (5,), "num_seqs": 4, **kwargs})


def test_continuous_network_has_rl_games_attributes_and_tuple():
    net = build({"space": CONTINUOUS, "mlp": MLP})
    assert net.units == [16, 8] and not net.separate and not net.is_rnn() and net.get_aux_loss() is None
    assert [k for k in net.state_dict()] == ["actor_mlp.0.weight", "actor_mlp.0.bias", "actor_mlp.2.weight",
                                             "actor_mlp.2.bias", "value.weight", "value.bias", "mu.weight",
                                             "mu.bias", "sigma.weight", "sigma.bias"]
    mu, sigma, value, states = net({"obs": torch.randn(6, 5)})
    assert mu.shape == sigma.shape == (6, 3) and value.shape == (6, 1) and states is None
    # rl_games 2.0's const sigma_init on a learned sigma head: zero weight, the value in the bias, so the initial
    # std is the same whatever the input
    assert torch.all(net.sigma.weight == 0) and torch.all(net.sigma.bias == 0.5) and torch.all(sigma == 0.5)


def test_discrete_multi_discrete_and_central_value_heads():
    logits, value, _ = build({"space": {"discrete": None}, "mlp": MLP})({"obs": torch.randn(2, 5)})
    assert logits.shape == (2, 3) and value.shape == (2, 1)
    multi = build({"space": {"multi_discrete": None}, "mlp": MLP, "separate": True}, actions_num=[3, 2])
    heads, value, _ = multi({"obs": torch.randn(2, 5)})
    assert [h.shape for h in heads] == [(2, 3), (2, 2)] and isinstance(multi.critic_mlp, nn.Sequential)
    params, _ = MultiCategorical([3, 2]).params_from_network((heads, value, None))
    assert params.shape == (2, 5)  # rl_games' list of logits joins rlchain's flat layout
    value, states = build({"mlp": MLP, "central_value": True}, actions_num=1, value_size=2)({"obs": torch.randn(2, 5)})
    assert value.shape == (2, 2) and states is None


@pytest.mark.parametrize("rnn, separate, count", [("lstm", False, 2), ("gru", False, 1), ("lstm", True, 4),
                                                  ("gru", True, 2)])
def test_recurrent_states_layout_and_sequences(rnn, separate, count):
    net = build({"space": {"discrete": None}, "mlp": MLP, "separate": separate,
                 "rnn": {"name": rnn, "units": 6, "layers": 1, "layer_norm": True}})
    states = net.get_default_rnn_state()
    assert len(states) == count and all(s.shape == (1, 4, 6) for s in states)
    obs, dones = torch.randn(4 * 3, 5), torch.zeros(12, dtype=torch.bool)
    logits, value, new = net({"obs": obs, "rnn_states": states, "seq_length": 3, "dones": dones})
    assert logits.shape == (12, 3) and len(new) == count and new[0].shape == (1, 4, 6)
    step, _, _ = net({"obs": obs.view(4, 3, 5)[:, 0], "rnn_states": states})  # one step per sequence
    assert torch.allclose(step, logits.view(4, 3, 3)[:, 0], atol=1e-6)


def test_cnn_trunk_permutes_channels_last_images():
    params = {"space": {"discrete": None}, "mlp": MLP, "cnn": {
        "type": "conv2d", "activation": "relu", "initializer": {"name": "orthogonal_initializer", "gain": 1.4},
        "convs": [{"filters": 4, "kernel_size": 3, "strides": 2, "padding": 0}]}}
    net = build(params, input_shape=(9, 9, 3))
    assert net._calc_input_size((3, 9, 9), net.actor_cnn) == 4 * 4 * 4
    logits, _, _ = net({"obs": torch.rand(2, 9, 9, 3)})
    assert logits.shape == (2, 3)


@pytest.mark.parametrize("cls", [LSTMWithDones, GRUWithDones])
def test_recurrent_layer_restarts_at_episode_starts(cls):
    torch.manual_seed(0)
    layer = cls(input_size=3, hidden_size=4, num_layers=1)
    x = torch.randn(5, 2, 3)
    dones = torch.zeros(5, 2, 1)
    dones[3, 1] = 1  # env 1's step 3 starts an episode
    out, _ = layer(x, None, dones)
    fresh, _ = layer(x[3:, 1:], None)
    assert torch.allclose(out[3:, 1:], fresh, atol=1e-6)
    whole, _ = layer(x[:, :1], None)
    assert torch.allclose(out[:, :1], whole, atol=1e-6)  # env 0 never restarts


def test_base_network_helpers_by_rl_games_names():
    base = network_builder.NetworkBuilder.BaseNetwork()
    mlp = base._build_mlp(4, [8, 2], "relu", nn.Linear, norm_func_name="layer_norm", norm_only_first_layer=True)
    assert [type(m).__name__ for m in mlp] == ["Linear", "ReLU", "LayerNorm", "Linear", "ReLU"]
    assert base._build_mlp(4, [8, 8], "tanh", nn.Linear, d2rl=True)(torch.randn(2, 4)).shape == (2, 8)
    weight = torch.empty(3, 3)
    base.init_factory.create(name="const_initializer", val=2.0)(weight)
    assert torch.all(weight == 2.0)
    base.init_factory.create(name="variance_scaling_initializer", scale=2.0)(weight)
    assert isinstance(base.activations_factory.create("swish"), nn.SiLU)
    assert base.get_default_rnn_state() is None and base.get_aux_loss() is None and not base.is_rnn()
    with pytest.raises(ValueError, match="rnn.name: expected lstm, gru or identity"):
        base._build_rnn("transformer", 3, 3, 1)


def test_running_mean_std_matches_the_data():
    data = torch.randn(1000, 3, dtype=torch.float64) * 3 + 1
    rms = RunningMeanStd((3,))
    for chunk in data.split(100):
        rms(chunk.float())
    # rl_games' statistics start from one pseudo-sample of mean 0, variance 1
    assert np.allclose(rms.running_mean.numpy(), (data.sum(0) / 1001).numpy(), atol=1e-5)
    assert np.allclose(rms.running_var.numpy(), data.var(0, unbiased=False).numpy(), rtol=1e-2)
    rms.eval()
    x = torch.randn(4, 3)
    assert torch.allclose(rms(rms(x), denorm=True), x, atol=1e-4)
    assert set(rms.state_dict()) == {"running_mean", "running_var", "count"}


def test_model_builder_builds_rl_games_models():
    params = {"model": {"name": "continuous_a2c_logstd"}, "network": {"name": "actor_critic", "space": CONTINUOUS,
                                                                       "mlp": MLP}}
    model = model_builder.ModelBuilder().load(params)
    assert isinstance(model, models.ModelA2CContinuousLogStd)
    net = model.build({"actions_num": 3, "input_shape": (5,), "normalize_input": True, "normalize_value": True})
    out = net({"is_train": False, "obs": torch.randn(4, 5)})
    assert out["actions"].shape == (4, 3) and out["neglogpacs"].shape == (4,) and out["values"].shape == (4, 1)
    train = net({"is_train": True, "obs": torch.randn(4, 5), "prev_actions": out["actions"]})
    assert train["prev_neglogp"].shape == (4,) and train["entropy"].shape == (4,)
    assert "running_mean_std.running_mean" in net.state_dict() and "a2c_network.mu.weight" in net.state_dict()


def test_register_network_takes_rl_games_callables(scoped_registries):
    model_builder.register_network("how_to", lambda **kwargs: network_builder.A2CBuilder())
    block = {"name": "how_to", "space": {"multi_discrete": None}, "mlp": MLP}
    net = instantiate(NETWORKS.get("how_to"), block, actions_num=5, input_shape=(5,), value_size=1, num_seqs=2,
                      action_space=gym.spaces.MultiDiscrete([3, 2]), observation_space=None)
    assert isinstance(net, network_builder.A2CBuilder.Network) and len(net.logits) == 2  # per-dimension heads
    assert "how_to" in model_builder.NetworkBuilder().network_factory._builders


def test_sac_player_rescales_squashed_actions_per_dimension():
    from types import SimpleNamespace

    from rlchain.rl_games.algos_torch.players import SACPlayer

    player = SACPlayer.__new__(SACPlayer)  # only the action space matters here
    player.action_space = SimpleNamespace(low=np.array([-0.4, 0.0], np.float32), high=np.array([0.4, 2.0], np.float32))
    out = player.rescale_actions(torch.tensor([[1.0, -1.0], [0.5, 0.25], [-2.0, 2.0]]))
    assert torch.allclose(out, torch.tensor([[0.4, 0.0], [0.2, 1.25], [-0.4, 2.0]]))


def test_a2c_network_is_rlchains_actor_critic_network():
    net = build({"space": {"discrete": None}, "mlp": MLP, "rnn": {"name": "gru", "units": 6, "layers": 1}})
    assert isinstance(net, ActorCriticNetwork) and isinstance(net.rnn, RecurrentLayer)
    assert isinstance(net, network_builder.NetworkBuilder.BaseNetwork)  # and rl_games' helpers
    assert isinstance(net.actor_cnn, nn.Sequential) and len(net.actor_cnn) == 0  # rl_games' empty defaults


class RlGamesForward(network_builder.A2CBuilder.Network):
    """A subclass whose forward calls its modules as rl_games' own A2CBuilder.Network.forward does."""

    def forward(self, obs_dict):
        obs, states = obs_dict["obs"], obs_dict.get("rnn_states")
        seq_length, dones = obs_dict.get("seq_length", 1), obs_dict.get("dones")
        out = self.actor_mlp(self.actor_cnn(obs).contiguous().view(obs.size(0), -1))
        batch = out.size(0) // seq_length
        out = out.reshape(batch, seq_length, -1).transpose(0, 1)
        if dones is not None:
            dones = dones.reshape(batch, seq_length, -1).transpose(0, 1)
        if len(states) == 1:
            states = states[0]
        out, states = self.rnn(out, states, dones, obs_dict.get("bptt_len", 0))
        out = self.layer_norm(out.transpose(0, 1).contiguous().reshape(out.size(0) * out.size(1), -1))
        if type(states) is not tuple:
            states = (states,)
        return self.logits(out), self.value_act(self.value(out)), states


@pytest.mark.parametrize("rnn", ["lstm", "gru"])
def test_a_forward_written_the_rl_games_way_gives_the_networks_outputs(rnn):
    torch.manual_seed(0)
    block = {"space": {"discrete": None}, "mlp": MLP, "rnn": {"name": rnn, "units": 6, "layers": 1,
                                                              "layer_norm": True}}
    net = RlGamesForward(block, actions_num=3, input_shape=(5,), num_seqs=4)
    states = tuple(torch.randn_like(s) for s in net.get_default_rnn_state())
    dones = torch.zeros(12, dtype=torch.bool)
    dones[4] = True  # sequence 1 starts an episode at its second step
    inputs = {"obs": torch.randn(12, 5), "rnn_states": states, "seq_length": 3, "dones": dones}
    theirs = net(dict(inputs))
    ours = ActorCriticNetwork.forward(net, dict(inputs))
    for a, b in zip(theirs[:2], ours[:2]):
        assert torch.allclose(a, b, atol=1e-6)
    assert all(torch.allclose(a, b, atol=1e-6) for a, b in zip(theirs[2], ours[2]))


def test_a_bad_value_in_the_block_is_one_line_naming_the_key():
    from rlchain.config.errors import ConfigError

    with pytest.raises(ConfigError, match="params.network.rnn.name"):
        build({"space": {"discrete": None}, "mlp": MLP, "rnn": {"name": "identity", "units": 6, "layers": 1}})


def test_keys_the_network_does_not_know_are_left_to_the_subclass(scoped_registries):
    class Reads(network_builder.A2CBuilder.Network):
        def load(self, params):
            super().load(params)
            self.disc_units = params["disc"]["units"]  # a key of the subclass's own (IsaacGymEnvs' AMP reads one)

    class Builder(network_builder.A2CBuilder):
        def build(self, name, **kwargs):
            return Reads(self.params, **kwargs)

    model_builder.register_network("reads_disc", Builder)
    block = {"name": "reads_disc", "space": {"discrete": None}, "mlp": MLP, "disc": {"units": [4]}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing left unread
        net = instantiate(NETWORKS.get("reads_disc"), block, actions_num=3, input_shape=(5,), value_size=1,
                          num_seqs=1, action_space=gym.spaces.Discrete(3), observation_space=None)
    assert net.disc_units == [4]
    with pytest.warns(UserWarning, match="typo_key"):
        instantiate(NETWORKS.get("reads_disc"), {**block, "typo_key": 1}, actions_num=3, input_shape=(5,),
                    value_size=1, num_seqs=1, action_space=gym.spaces.Discrete(3), observation_space=None)
