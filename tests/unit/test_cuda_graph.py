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
from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.ppo import agent as agent_module
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.algos.ppo.graph_step import GraphedAct
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


def _agent(device, graphed, monkeypatch, **config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update({"num_actors": 8, "horizon_length": 8, "minibatch_size": 16, "mini_epochs": 2,
                                    "learning_rate": 1e-3, "lr_schedule": "adaptive", **config})
    cfg = parse_params(raw, "cfg.yaml").config
    model = ActorCritic(MLP(), make_distribution("continuous_a2c_logstd", gym.spaces.Box(-1.0, 1.0, (2,)), False),
                        (3,), 1, False, False).to(device)
    with monkeypatch.context() as patch:  # the graphed agent on any device (on a CPU it never captures)
        patch.setattr(agent_module, "use_cuda_graph", lambda cfg, device: graphed)
        agent = PPOAgent(model, cfg, torch.device(device))
    if graphed and device == "cpu":
        agent._graph.warmup = agent._graph._warmup_left = 10 ** 9
    return agent


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


def _same_update(device, monkeypatch, epochs=3):
    eager, graphed = _agent(device, False, monkeypatch), _agent(device, True, monkeypatch)
    for _ in range(epochs):
        out_e, out_g = eager.update(_rollout(eager), 0.0), graphed.update(_rollout(graphed), 0.0)
        for key in ("a_loss", "c_loss", "entropy", "kl", "grad_norm", "clip_frac"):
            assert out_g[key] == pytest.approx(out_e[key], rel=1e-4, abs=1e-6), key
        assert out_g["lr"] == pytest.approx(out_e["lr"])
    for a, b in zip(eager.params, graphed.params):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-5)
    return eager, graphed


def test_the_sync_free_step_trains_what_the_eager_step_does(monkeypatch):
    _, graphed = _same_update("cpu", monkeypatch)
    assert graphed.optimizer.param_groups[0]["capturable"] is True
    assert isinstance(graphed.optimizer.param_groups[0]["lr"], torch.Tensor)


def test_a_non_finite_step_raises_and_leaves_the_parameters_as_they_were(monkeypatch):
    agent = _agent("cpu", True, monkeypatch)
    agent.update(_rollout(agent), 0.0)
    before = [p.detach().clone() for p in agent.params]
    with pytest.raises(DivergenceError, match="in the PPO update"):
        agent.update(_rollout(agent, nan=True), 0.0)
    for a, b in zip(before, agent.params):
        assert torch.equal(a, b)
    assert all(torch.isfinite(v).all() for state in agent.optimizer.state.values() for v in state.values())


def test_the_live_learning_rate_reaches_the_captured_optimizer(monkeypatch):
    agent = _agent("cpu", True, monkeypatch, lr_schedule="constant")
    agent.set_hyperparam("learning_rate", 0.0)
    before = [p.detach().clone() for p in agent.params]
    agent.update(_rollout(agent), 0.0)
    assert all(torch.equal(a, b) for a, b in zip(before, agent.params))
    agent.scale_lr(1.0)
    agent.set_hyperparam("learning_rate", 1e-3)
    agent.update(_rollout(agent), 0.0)
    assert any(not torch.equal(a, b) for a, b in zip(before, agent.params))


def test_checkpoints_load_both_ways_and_a_load_captures_again(monkeypatch):
    graphed, eager = _agent("cpu", True, monkeypatch), _agent("cpu", False, monkeypatch)
    graphed.update(_rollout(graphed), 0.0)
    state = graphed.state_dict()
    group = state["optimizer"]["param_groups"][0]
    assert group["capturable"] is False and isinstance(group["lr"], float)  # an eager run loads it
    eager.load_state_dict(copy.deepcopy(state))
    eager.update(_rollout(eager), 0.0)
    assert isinstance(eager.optimizer.param_groups[0]["lr"], float)
    graphed._graph.graph = "captured"  # stands for a recorded graph: a load must drop it
    graphed.load_state_dict(eager.state_dict())
    assert graphed._graph.graph is None and graphed.optimizer.param_groups[0]["capturable"] is True
    assert graphed.optimizer.param_groups[0]["lr"] is graphed._lr_step
    assert graphed.lr == pytest.approx(eager.lr) and float(graphed._lr_live) == pytest.approx(eager.lr)
    graphed.update(_rollout(graphed), 0.0)


def test_cuda_graph_on_a_cpu_warns_and_runs_eagerly(caplog):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"]["cuda_graph"] = True
    cfg = parse_params(raw, "cfg.yaml").config
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        assert agent_module.use_cuda_graph(cfg, torch.device("cpu")) is False
    assert any("cuda_graph: True needs a CUDA device" in r.getMessage() for r in caplog.records)


def _overrides(tmp_path, *extra):
    return [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=1", "params.config.print_stats=false",
            "params.config.cuda_graph=True", *extra]


def test_cuda_graph_must_be_a_bool(tmp_path):
    with pytest.raises(ConfigError, match="cuda_graph"):
        Runner().load(os.path.join(CONFIGS, "ppo_torch_cartpole.yaml"),
                      _overrides(tmp_path, "params.config.cuda_graph=sometimes"))


@pytest.mark.parametrize("config,override,expected", [
    ("ppo_torch_pendulum.yaml", "params.config.mixed_precision=fp16",
     r"params\.config\.cuda_graph: False with mixed_precision fp16"),
    ("ppo_cartpole_masked_velocity_rnn.yaml", "params.config.print_stats=false",
     r"params\.config\.cuda_graph: False for an RNN network"),
])
def test_cuda_graph_refuses_what_it_cannot_capture(tmp_path, config, override, expected):
    runner = Runner().load(os.path.join(CONFIGS, config), _overrides(tmp_path, override))
    with pytest.raises(ConfigError, match=expected):
        runner.train()


@CUDA
def test_on_cuda_the_captured_step_trains_what_the_eager_step_does(monkeypatch):
    _, graphed = _same_update("cuda", monkeypatch)
    assert graphed._graph.captures == 1 and graphed._graph.graph is not None


@CUDA
def test_on_cuda_a_non_finite_replay_raises_and_a_load_captures_again(monkeypatch):
    agent = _agent("cuda", True, monkeypatch)
    agent.update(_rollout(agent), 0.0)  # 8 minibatch steps: warmed up and captured
    assert agent._graph.captures == 1
    before = [p.detach().clone() for p in agent.params]
    with pytest.raises(DivergenceError):
        agent.update(_rollout(agent, nan=True), 0.0)
    assert all(torch.equal(a, b) for a, b in zip(before, agent.params))
    agent.load_state_dict(agent.state_dict())
    agent.update(_rollout(agent), 0.0)
    agent.update(_rollout(agent), 0.0)
    assert agent._graph.captures == 2
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
