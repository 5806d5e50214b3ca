"""``cuda_graph``: the sync-free minibatch step equals the eager one, a non-finite step raises and leaves the
parameters alone, checkpoints stay portable both ways, the config checks; on CUDA (skipped here without
one) the captured graph trains what the eager step does and is captured again after a state load."""

import copy
import logging
import os

import gymnasium as gym
import pytest
import torch
import torch.nn as nn

from rlchain import Runner
from rlchain.algos.core.storage import Batch, RolloutStorage
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.algos.ppo.graph_step import GraphedAct, GraphedStep, resolve_cuda_graph
from rlchain.config.errors import ConfigError
from rlchain.config.load import parse_params
from rlchain.errors import DivergenceError
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from tests.conftest import BASE, CONFIGS

CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")


class MLP(nn.Module):
    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.body = nn.Sequential(nn.Linear(3, 32), nn.ELU())
        self.mu = nn.Linear(32, 2)
        self.value = nn.Linear(32, 1)
        self.logstd = nn.Parameter(torch.zeros(2))

    def forward(self, input_dict):
        h = self.body(input_dict["obs"])
        return self.mu(h), self.logstd.expand(h.shape[0], 2), self.value(h), None


def _agent(device, graphed, **config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update({"num_actors": 8, "horizon_length": 8, "minibatch_size": 16, "mini_epochs": 2,
                                    "learning_rate": 1e-3, "lr_schedule": "adaptive", **config})
    cfg = parse_params(raw, "cfg.yaml").config
    model = ActorCritic(MLP(), make_distribution("continuous_a2c_logstd", gym.spaces.Box(-1.0, 1.0, (2,)), False),
                        (3,), 1, False, False).to(device)
    return PPOAgent(model, cfg, torch.device(device), cuda_graph=graphed)  # on a CPU it never captures


def _rollout(agent, nan=False):
    device = next(agent.model.parameters()).device
    storage = RolloutStorage(8, 8, (3,), torch.float32, (2,), torch.float32, 4, 1, device)
    gen = torch.Generator().manual_seed(1)
    for t in range(8):
        obs = torch.randn(8, 3, generator=gen).to(device)
        with torch.no_grad():
            params, values, _ = agent.model.evaluate(obs, (), None, 1, None)
        actions = torch.randn(8, 2, generator=gen).to(device)
        storage.add(t, obs, actions, agent.model.dist.log_prob(params, actions), values, params)
    storage.advantages.copy_(torch.randn(8, 8, 1, generator=gen))
    storage.returns.copy_(torch.randn(8, 8, 1, generator=gen))
    if nan:
        storage.returns[3, 0] = float("nan")  # env 0: in the first minibatch
    return storage


def _same_update(device, epochs=3):
    eager, graphed = _agent(device, False), _agent(device, True)
    for _ in range(epochs):
        out_e, out_g = eager.update(_rollout(eager), 0.0), graphed.update(_rollout(graphed), 0.0)
        for key in ("a_loss", "c_loss", "entropy", "kl", "grad_norm", "clip_frac"):
            assert out_g[key] == pytest.approx(out_e[key], rel=1e-4, abs=1e-6), key
        assert out_g["lr"] == pytest.approx(out_e["lr"])
    for a, b in zip(eager.params, graphed.params):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-5)
    return eager, graphed


def test_the_sync_free_step_trains_what_the_eager_step_does():
    _, graphed = _same_update("cpu")
    assert graphed.optimizer.param_groups[0]["capturable"] is True
    assert isinstance(graphed.optimizer.param_groups[0]["lr"], torch.Tensor)


def test_a_non_finite_step_raises_and_leaves_the_parameters_as_they_were():
    agent = _agent("cpu", True)
    agent.update(_rollout(agent), 0.0)
    before = [p.detach().clone() for p in agent.params]
    with pytest.raises(DivergenceError, match="in the PPO update"):
        agent.update(_rollout(agent, nan=True), 0.0)
    for a, b in zip(before, agent.params):
        assert torch.equal(a, b)
    assert all(torch.isfinite(v).all() for state in agent.optimizer.state.values() for v in state.values())


def test_the_live_learning_rate_reaches_the_captured_optimizer():
    agent = _agent("cpu", True, lr_schedule="constant")
    agent.set_hyperparam("learning_rate", 0.0)
    before = [p.detach().clone() for p in agent.params]
    agent.update(_rollout(agent), 0.0)
    assert all(torch.equal(a, b) for a, b in zip(before, agent.params))
    agent.scale_lr(1.0)
    agent.set_hyperparam("learning_rate", 1e-3)
    agent.update(_rollout(agent), 0.0)
    assert any(not torch.equal(a, b) for a, b in zip(before, agent.params))


def test_checkpoints_load_both_ways_and_a_load_captures_again():
    graphed, eager = _agent("cpu", True), _agent("cpu", False)
    graphed.update(_rollout(graphed), 0.0)
    state = graphed.state_dict()
    group = state["optimizer"]["param_groups"][0]
    assert group["capturable"] is False and isinstance(group["lr"], float)  # an eager run loads it
    eager.load_state_dict(copy.deepcopy(state))
    eager.update(_rollout(eager), 0.0)
    assert isinstance(eager.optimizer.param_groups[0]["lr"], float)
    graphed.graphed.graph = "captured"  # stands for a recorded graph: a load must drop it
    graphed.load_state_dict(eager.state_dict())
    assert graphed.graphed.graph is None and graphed.optimizer.param_groups[0]["capturable"] is True
    assert graphed.optimizer.param_groups[0]["lr"] is graphed.lr_step
    assert graphed.lr == pytest.approx(eager.lr) and float(graphed.lr_live) == pytest.approx(eager.lr)
    graphed.update(_rollout(graphed), 0.0)


def _cfg(**config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update(config)
    return parse_params(raw, "cfg.yaml").config


class BuiltIn(MLP):
    """Stands for one of rlchain's own networks (auto's test is the class's module)."""


BuiltIn.__module__ = "rlchain.networks.actor_critic"


class UserNet(MLP):
    pass


UserNet.__module__ = "my_package.networks"


def _resolve(cfg, network=None, rnn=False, device="cuda", distributed=False):
    return resolve_cuda_graph(cfg, network or BuiltIn(), rnn, torch.device(device), distributed, "cfg.yaml")


def test_cuda_graph_on_a_cpu_warns_when_asked_for_and_runs_eagerly(caplog):
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        assert _resolve(_cfg(cuda_graph=True), device="cpu") is False
        assert _resolve(_cfg(), device="cpu") is False  # auto: quietly off
    assert [r.getMessage() for r in caplog.records if "cuda_graph" in r.getMessage()] == [
        "cuda_graph: True needs a CUDA device; the PPO update runs eagerly on cpu"]


@pytest.mark.parametrize("case,auto,explicit", [
    ({}, True, True),
    ({"rnn": True}, False, "for an RNN network"),
    ({"mixed_precision": "fp16"}, False, "float16 mixed precision"),
    ({"distributed": True}, False, "with multi_gpu"),
    ({"torch_compile": "reduce-overhead"}, False, "reduce-overhead or max-autotune"),
    ({"torch_compile": True}, False, True),  # auto: not measured together; True: allowed
    ({"compile_update": True}, False, True),
    ({"mixed_precision": "bf16"}, False, True),  # auto: not measured together; True: bf16 autocast, no cache
    ({"network": UserNet()}, False, True),  # auto: a user's forward pass might sync with the host
])
def test_where_auto_turns_cuda_graphs_on_and_true_refuses(case, auto, explicit):
    case = dict(case)
    kw = {"network": case.pop("network", None), "rnn": case.pop("rnn", False),
          "distributed": case.pop("distributed", False)}
    assert _resolve(_cfg(**case), **kw) is auto
    if explicit is True:
        assert _resolve(_cfg(cuda_graph=True, **case), **kw) is True
    else:
        with pytest.raises(ConfigError, match=rf"params\.config\.cuda_graph: .*{explicit}"):
            _resolve(_cfg(cuda_graph=True, **case), **kw)
    assert _resolve(_cfg(cuda_graph=False, **case), **kw) is False


def _overrides(tmp_path, *extra):
    return [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=1", "params.config.print_stats=false",
            "params.config.cuda_graph=True", *extra]


def test_cuda_graph_must_be_a_bool(tmp_path):
    with pytest.raises(ConfigError, match="cuda_graph"):
        Runner().load(os.path.join(CONFIGS, "ppo_torch_cartpole.yaml"),
                      _overrides(tmp_path, "params.config.cuda_graph=sometimes"))


@pytest.mark.parametrize("config,override,expected", [
    ("ppo_torch_pendulum.yaml", "params.config.mixed_precision=fp16",
     r"params\.config\.cuda_graph: False with float16 mixed precision"),
    ("ppo_cartpole_masked_velocity_rnn.yaml", "params.config.print_stats=false",
     r"params\.config\.cuda_graph: False for an RNN network"),
])
def test_cuda_graph_refuses_what_it_cannot_capture(tmp_path, config, override, expected):
    runner = Runner().load(os.path.join(CONFIGS, config), _overrides(tmp_path, override))
    with pytest.raises(ConfigError, match=expected):
        runner.train()


@CUDA
def test_on_cuda_the_captured_step_trains_what_the_eager_step_does():
    _, graphed = _same_update("cuda")
    assert graphed.graphed.captures == 1 and graphed.graphed.graph is not None


@CUDA
def test_on_cuda_a_non_finite_replay_raises_and_a_load_captures_again():
    agent = _agent("cuda", True)
    agent.update(_rollout(agent), 0.0)  # 8 minibatch steps: warmed up and captured
    assert agent.graphed.captures == 1
    before = [p.detach().clone() for p in agent.params]
    with pytest.raises(DivergenceError):
        agent.update(_rollout(agent, nan=True), 0.0)
    assert all(torch.equal(a, b) for a, b in zip(before, agent.params))
    agent.load_state_dict(agent.state_dict())
    agent.update(_rollout(agent), 0.0)
    agent.update(_rollout(agent), 0.0)
    assert agent.graphed.captures == 2
    assert all(torch.isfinite(p).all() for p in agent.params)


def _check_act(device):
    model = ActorCritic(MLP(), make_distribution("continuous_a2c_logstd", gym.spaces.Box(-1.0, 1.0, (2,)), False),
                        (3,), 1, False, False).to(device)
    graphed = GraphedAct(model.act)
    for _ in range(6):  # 3 warm-up calls, the capture, 2 replays
        obs = torch.randn(8, 3, device=device)
        out = graphed(obs)
        with torch.no_grad():
            params, values, _ = model.evaluate(obs, (), None, 1, None)
        torch.testing.assert_close(out["params"], params)  # this call's obs, the current parameters
        torch.testing.assert_close(out["values"], values)
        torch.testing.assert_close(out["log_probs"], model.dist.log_prob(params, out["actions"]))
        with torch.no_grad():  # an optimizer step changes the parameters in place: the graph sees it
            for p in model.parameters():
                p.add_(0.01)
    return graphed


def test_the_act_step_wrapper_acts_on_each_calls_obs():
    assert _check_act("cpu").graph is None


@CUDA
def test_on_cuda_the_captured_act_step_follows_obs_and_parameters():
    graphed = _check_act("cuda")
    assert graphed.graph is not None


@CUDA
def test_on_cuda_a_step_that_cannot_be_captured_runs_eagerly_with_a_warning(caplog):
    weight = torch.ones(3, device="cuda", requires_grad=True)
    calls = []

    def step(batch, coef, reference):  # .item() syncs with the host: no graph can hold it
        calls.append(float((batch.obs.sum() * weight.sum()).item()))
        return batch.obs.sum().reshape(1), reference

    graphed = GraphedStep(step, lambda: None, warmup=1)
    batch = Batch(obs=torch.ones(4, 3, device="cuda"), actions=None, log_probs=None, values=None, returns=None,
                  advantages=None, params=torch.zeros(4, 2, device="cuda"))
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        for _ in range(3):
            out, _ = graphed(batch, torch.zeros((), device="cuda"), torch.zeros(4, 2, device="cuda"))
    assert graphed.eager and graphed.graph is None and float(out) == 12.0
    assert any("could not capture the PPO minibatch step" in r.getMessage() for r in caplog.records)


def test_a_changed_hyperparameter_drops_the_captured_step():
    agent = _agent("cpu", True)
    agent.graphed.graph = "captured"  # stands for a recorded graph holding e_clip as a constant
    agent.config_changed()
    assert agent.graphed.graph is None
