"""RNN support: the recurrent layer, sequence minibatches and rollout/training consistency."""

from __future__ import annotations

import gymnasium as gym
import pytest
import torch

from rlchain.algos.core.storage import RolloutStorage
from rlchain.config.fields import parse_dataclass
from rlchain.config.network import NetworkConfig, RnnConfig
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import Categorical
from rlchain.networks.actor_critic import ActorCriticNetwork
from rlchain.networks.rnn import RecurrentLayer, flat_sequences


def _network(rnn: dict, separate: bool = False, obs_dim: int = 3) -> ActorCriticNetwork:
    cfg = parse_dataclass(NetworkConfig, {"separate": separate, "space": {"discrete": None},
                                          "mlp": {"units": [8]}, "rnn": rnn}, "params.network", "t")
    return ActorCriticNetwork(cfg, (obs_dim,), 2, 1, continuous=False)


FRAME = (10, 10, 2)  # a tiny channels-last uint8 "Atari" frame stack


def _cnn_network(rnn: dict, separate: bool = False) -> ActorCriticNetwork:
    """rl_games' ppo_pacman_torch_rnn.yaml in miniature: conv2d (permute_input) -> mlp -> lstm."""
    init = {"name": "glorot_normal_initializer", "gain": 1.4142}
    cfg = parse_dataclass(NetworkConfig, {
        "separate": separate, "space": {"discrete": None},
        "cnn": {"type": "conv2d", "activation": "relu", "initializer": init,
                "convs": [{"filters": 4, "kernel_size": 3, "strides": 2, "padding": 0}]},
        "mlp": {"units": [8], "activation": "relu", "initializer": init}, "rnn": rnn}, "params.network", "t")
    return ActorCriticNetwork(cfg, FRAME, 3, 1, continuous=False)


@pytest.mark.parametrize("name", ["lstm", "gru"])
def test_sequence_forward_equals_step_by_step(name):
    torch.manual_seed(0)
    layer = RecurrentLayer(4, RnnConfig(name=name, units=5, layers=2))
    batch, length = 3, 4
    x = torch.randn(batch * length, 4)
    resets = torch.zeros(batch * length, dtype=torch.bool)
    resets[1 * length + 2] = True  # sequence 1 starts an episode at its third step
    states = tuple(torch.randn_like(s) for s in layer.initial_state(batch, torch.device("cpu")))
    out, final = flat_sequences(layer, x, states, resets, length)
    # the same computation one step at a time, zeroing the state where an episode starts
    seq_x = x.reshape(batch, length, 4)
    seq_r = resets.reshape(batch, length)
    hidden = states
    expected = []
    for t in range(length):
        keep = (~seq_r[:, t]).float().view(1, -1, 1)
        hidden = tuple(h * keep for h in hidden)
        step, hidden = flat_sequences(layer, seq_x[:, t], hidden, None, 1)
        expected.append(step)
    expected = torch.stack(expected, 1).reshape(batch * length, -1)
    assert torch.allclose(out, expected, atol=1e-6)
    for a, b in zip(final, hidden):
        assert torch.allclose(a, b, atol=1e-6)


def test_reset_cuts_memory():
    torch.manual_seed(0)
    layer = RecurrentLayer(2, RnnConfig(name="gru", units=4))
    x = torch.randn(4, 2)
    zero = layer.initial_state(1, torch.device("cpu"))
    other = (torch.ones_like(zero[0]),)
    resets = torch.tensor([False, False, True, False])
    out_a, _ = flat_sequences(layer, x, zero, resets, 4)
    out_b, _ = flat_sequences(layer, x, other, resets, 4)
    assert not torch.allclose(out_a[:2], out_b[:2])  # before the reset the initial state matters
    assert torch.allclose(out_a[2:], out_b[2:])      # after it, it does not


def test_sequence_minibatches_keep_steps_in_order():
    horizon, envs, length = 8, 3, 4
    storage = RolloutStorage(horizon, envs, (1,), torch.float32, (), torch.long, 2, 1, torch.device("cpu"),
                             state_shapes=((1, envs, 2),))
    for t in range(horizon):
        obs = torch.tensor([[t * 10.0 + e] for e in range(envs)])
        state = torch.tensor([[[t * 10.0 + e, -1.0] for e in range(envs)]])
        storage.add(t, obs, torch.zeros(envs, dtype=torch.long), torch.zeros(envs), torch.zeros(envs, 1),
                    torch.zeros(envs, 2), None, (state,), torch.tensor([t == 5] * envs))
    seen = 0
    for batch in storage.sequence_minibatches(8, length, torch.zeros(horizon, envs)):
        assert batch.seq_length == length and batch.states[0].shape == (1, 2, 2)
        seqs = batch.obs.reshape(-1, length)
        for i, seq in enumerate(seqs):
            start = seq[0].item()
            t0, env = divmod(int(start), 10)
            assert t0 % length == 0
            assert seq.tolist() == [start + 10 * k for k in range(length)]  # consecutive steps, one env
            assert batch.states[0][0, i, 0].item() == start                 # the state entering it
            assert batch.resets.reshape(-1, length)[i].tolist() == [t0 + k == 5 for k in range(length)]
            seen += 1
    assert seen == horizon // length * envs


def test_sequence_minibatches_reject_bad_lengths():
    storage = RolloutStorage(6, 2, (1,), torch.float32, (), torch.long, 2, 1, torch.device("cpu"),
                             state_shapes=((1, 2, 2),))
    storage.filled = 6
    with pytest.raises(ValueError, match="seq_length"):
        next(storage.sequence_minibatches(4, 4, torch.zeros(6, 2)))


@pytest.mark.parametrize("separate", [False, True])
@pytest.mark.parametrize("kind", ["mlp", "cnn"])
def test_rollout_log_probs_match_training_evaluation(separate, kind):
    """What the rollout recorded must be what the update recomputes before any step (ratio 1).

    ``cnn``: the Atari RNN path (uint8 channels-last frames scaled and normalized, conv -> mlp ->
    LSTM with LayerNorm), whose large first-epoch KL turned out to be the optimisation, not this."""
    torch.manual_seed(0)
    if kind == "cnn":
        net = _cnn_network({"name": "lstm", "units": 6, "layer_norm": True}, separate=separate)
        shape, dtype, n = FRAME, torch.uint8, 3
    else:
        net = _network({"name": "lstm", "units": 6, "layers": 1}, separate=separate)
        shape, dtype, n = (3,), torch.float32, 2
    model = ActorCritic(net, Categorical(n), shape, 1, normalize_input=kind == "cnn", normalize_value=False)
    if model.running_mean_std is not None:  # statistics away from the identity, frozen between rollout and update
        model.update_normalizers(obs=torch.randint(0, 256, (16, *shape), dtype=torch.uint8))
    horizon, envs, length = 8, 4, 4
    states = model.initial_state(envs)
    storage = RolloutStorage(horizon, envs, shape, dtype, (), torch.long, n, 1, torch.device("cpu"),
                             state_shapes=tuple(tuple(s.shape) for s in states))
    resets = torch.ones(envs, dtype=torch.bool)
    for t in range(horizon):
        obs = torch.randint(0, 256, (envs, *shape), dtype=dtype) if kind == "cnn" else torch.randn(envs, 3)
        out = model.act(obs, states=states)
        storage.add(t, obs, out["actions"], out["log_probs"], out["values"], out["params"], None, states, resets)
        dones = torch.rand(envs) < 0.3
        keep = (~dones).float().view(1, -1, 1)
        states = tuple(s * keep for s in out["states"])
        resets = dones
    for batch in storage.sequence_minibatches(8, length, torch.zeros(horizon, envs)):
        params, values, _ = model.evaluate(batch.obs, batch.states, batch.resets, batch.seq_length)
        log_probs = model.dist.log_prob(params, batch.actions)
        assert torch.allclose(log_probs, batch.log_probs, atol=1e-5)
        assert torch.allclose(values, batch.values, atol=1e-5)


@pytest.mark.parametrize("before_mlp", [False, True])
def test_concat_output_appends_the_encoder_features(before_mlp):
    """rl_games' concat_output appends the cnn output (not the RNN's input, which after the MLP is
    the MLP output) to the RNN output after its LayerNorm, in both orders."""
    torch.manual_seed(0)
    net = _cnn_network({"name": "gru", "units": 5, "layer_norm": True, "concat_output": True,
                        "before_mlp": before_mlp})
    cnn_size = net.actor_cnn.out_size  # 4 filters * 4 * 4
    obs = torch.rand(6, *FRAME)
    states = net.get_default_rnn_state(2)
    out, _ = net._trunk(net.actor_layout, obs, states, None, 3, None, None)
    encoded = net.actor_cnn(obs)
    if before_mlp:
        assert net.actor_mlp.in_size == 5 + cnn_size
        rnn_out, _ = flat_sequences(net.rnn, encoded, states, None, 3)
        expected = net.actor_mlp(torch.cat([net.layer_norm(rnn_out), encoded], -1))
    else:
        assert net.actor_layout.out_size == 5 + cnn_size and net.logits.in_features == 5 + cnn_size
        rnn_out, _ = flat_sequences(net.rnn, net.actor_mlp(encoded), states, None, 3)
        expected = torch.cat([net.layer_norm(rnn_out), encoded], -1)
    assert torch.allclose(out, expected, atol=1e-6)


def test_rnn_config_errors(tmp_path):
    from rlchain.config.errors import ConfigError
    from rlchain.config.load import parse_params

    raw = {"params": {"algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
                      "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [8]},
                                  "rnn": {"name": "lstm", "units": 8}},
                      "config": {"env_name": "CartPole-v1", "num_actors": 2, "horizon_length": 6,
                                 "minibatch_size": 6, "seq_length": 4}}}
    with pytest.raises(ConfigError, match="params.config.seq_length: horizon_length 6 is not divisible"):
        parse_params(raw, "cfg.yaml")
    raw["params"]["network"]["rnn"]["name"] = "lstmm"
    with pytest.raises(ConfigError, match=r"params.network.rnn.name: 'lstmm' is not one of: lstm, gru"):
        parse_params(raw, "cfg.yaml")


def test_masked_velocity_env_hides_velocities():
    # rlchain.builtins registers the id; rl_games' shape: velocities zeroed
    from rlchain.registry import ensure_builtins

    ensure_builtins()
    env = gym.make("CartPoleMaskedVelocity-v1")
    obs, _ = env.reset(seed=0)
    assert obs.shape == (4,) and env.observation_space.shape == (4,)
    full = gym.make("CartPole-v1")
    full_obs, _ = full.reset(seed=0)
    obs, *_ = env.step(1)
    full_obs, *_ = full.step(1)
    assert obs[[1, 3]].tolist() == [0.0, 0.0] and full_obs[1] != 0.0
    assert obs[[0, 2]].tolist() == pytest.approx(full_obs[[0, 2]].tolist())


@pytest.mark.parametrize("name", ["lstm", "gru"])
def test_truncated_bptt_cuts_gradients_but_not_values(name):
    torch.manual_seed(0)
    layer = RecurrentLayer(3, RnnConfig(name=name, units=4))
    x = torch.randn(4, 3, requires_grad=True)  # one sequence of 4 steps
    states = layer.initial_state(1, torch.device("cpu"))
    full, _ = flat_sequences(layer, x, states, None, 4)
    cut, _ = flat_sequences(layer, x, states, None, 4, bptt_length=2)
    assert torch.allclose(full, cut)  # forward values are the same
    grad_full = torch.autograd.grad(full[3].sum(), x)[0]
    grad_cut = torch.autograd.grad(cut[3].sum(), x)[0]
    assert grad_full[0].abs().sum() > 0 and grad_full[1].abs().sum() > 0
    assert grad_cut[0].abs().sum() == 0 and grad_cut[1].abs().sum() == 0  # steps before the cut
    assert grad_cut[2].abs().sum() > 0 and grad_cut[3].abs().sum() > 0


def test_stepper_names_the_key_when_a_masked_policy_meets_an_env_without_masks():
    from rlchain.config.errors import ConfigError
    from rlchain.policy.stepper import PolicyStepper

    class NoMasks:
        def has_action_mask(self):
            return False

    model = ActorCritic(_network({"name": "gru", "units": 4}), Categorical(2), (3,), 1, False, False,
                        use_action_masks=True)
    with pytest.raises(ConfigError, match="params.config.use_action_masks"):
        PolicyStepper(model, 2, torch.device("cpu")).act(torch.zeros(2, 3), NoMasks())


def _count_calls(layer: RecurrentLayer) -> list:
    calls = []
    layer.rnn.register_forward_hook(lambda module, args, out: calls.append(args[0].shape[0]))
    return calls


@pytest.mark.parametrize("name", ["lstm", "gru"])
def test_masked_sequences_run_in_one_call_between_cuts(name):
    # the state is cut where an episode starts (any sequence) and detached every bptt steps: the layer runs in
    # one call from each cut to the next, with the outputs and gradients of one call per step
    torch.manual_seed(0)
    layer = RecurrentLayer(4, RnnConfig(name=name, units=5, layers=2))
    calls = _count_calls(layer)
    batch, length = 3, 8
    x = torch.randn(batch * length, 4, requires_grad=True)
    resets = torch.zeros(batch, length, dtype=torch.bool)
    resets[0, 3] = resets[2, 3] = resets[1, 5] = resets[1, 0] = True  # step 0's reset is the initial state's
    states = tuple(torch.randn_like(s) for s in layer.initial_state(batch, torch.device("cpu")))
    out, final = flat_sequences(layer, x, states, resets.flatten(), length, bptt_length=4)
    # steps 0-2, 3, 4 (bptt), 5-7 (an LSTM's one-step runs go through torch.lstm_cell, not the module)
    assert calls == ([3, 3] if name == "lstm" else [3, 1, 1, 3])
    hidden, expected = states, []
    for t in range(length):
        if t == 4:
            hidden = tuple(h.detach() for h in hidden)
        hidden = tuple(h * (~resets[:, t]).float().view(1, -1, 1) for h in hidden)
        step, hidden = layer.rnn(x.reshape(batch, length, 4)[:, t].unsqueeze(0), hidden if name == "lstm"
                                 else hidden[0])
        hidden = hidden if name == "lstm" else (hidden,)
        expected.append(step[0])
    expected = torch.stack(expected, 1).reshape(batch * length, -1)
    assert torch.allclose(out, expected, atol=1e-6)
    assert all(torch.allclose(a, b, atol=1e-6) for a, b in zip(final, hidden))
    weights = torch.linspace(-1, 1, out.numel()).view_as(out)
    grads = torch.autograd.grad((out * weights).sum(), [x, *layer.parameters()])
    reference = torch.autograd.grad((expected * weights).sum(), [x, *layer.parameters()])
    assert all(torch.allclose(a, b, atol=1e-5) for a, b in zip(grads, reference))


def test_one_lstm_step_on_the_cpu_is_the_cell_with_nn_lstms_outputs():
    # an env step of the rollout: torch.lstm_cell per layer instead of nn.LSTM's oneDNN kernel, the same values
    torch.manual_seed(0)
    layer = RecurrentLayer(4, RnnConfig(name="lstm", units=5, layers=2))
    calls = _count_calls(layer)
    for batch, module_calls in ((3, []), (65, [1])):  # many sequences: nn.LSTM, faster there
        x = torch.randn(1, batch, 4, requires_grad=True)
        states = tuple(torch.randn(2, batch, 5) for _ in range(2))
        out, (h, c) = layer(x, states)
        assert calls == module_calls
        with torch.no_grad():
            want, (want_h, want_c) = layer.rnn(x, states)
        calls.clear()
        assert torch.allclose(out, want, atol=1e-6) and torch.allclose(h, want_h, atol=1e-6)
        assert torch.allclose(c, want_c, atol=1e-6) and out.shape == (1, batch, 5)
        assert out.requires_grad  # the cell path trains too
