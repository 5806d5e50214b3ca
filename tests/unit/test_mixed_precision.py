"""``mixed_precision``: which dtype the PPO update autocasts to on each device, and a bf16 update on a CPU
(network passes in bfloat16, the losses, KL and stats in float32, close to the float32 update's)."""

import copy
import logging

import gymnasium as gym
import pytest
import torch
import torch.nn as nn

from rlchain.algos.core import precision
from rlchain.algos.core.precision import autocast_dtype
from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.config.load import parse_params
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from tests.conftest import BASE

CPU = torch.device("cpu")


@pytest.mark.parametrize("value,bf16_cpu,expected", [
    ("bf16", True, torch.bfloat16),  # asked for by name, on a CPU with AVX512-BF16 / AMX
    ("bf16", False, None),  # emulated bf16 is slower than float32: off, with a warning
    (True, True, None),  # rl_games YAMLs carry True for their GPUs; float32 on a CPU, as in rl_games
    ("fp16", True, None),  # float16 with a grad scaler is a CUDA path
    (False, True, None),
])
def test_cpu_autocasts_only_bf16_asked_for_by_name_on_a_bf16_cpu(value, bf16_cpu, expected):
    assert autocast_dtype(value, CPU, bf16_cpu=bf16_cpu) is expected


def test_bf16_on_a_cpu_without_it_warns_once(monkeypatch, caplog):
    monkeypatch.setattr(precision, "_warned", set())
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        autocast_dtype("bf16", CPU, bf16_cpu=False)
        autocast_dtype("bf16", CPU, bf16_cpu=False)
    warnings = [r.getMessage() for r in caplog.records if "no native bf16" in r.getMessage()]
    assert len(warnings) == 1 and "float32" in warnings[0]


class MLP(nn.Module):
    """A small Gaussian actor-critic whose hidden layer records the dtype it ran in."""

    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.body = nn.Sequential(nn.Linear(3, 32), nn.SiLU())
        self.mu = nn.Linear(32, 2)
        self.value = nn.Linear(32, 1)
        self.logstd = nn.Parameter(torch.zeros(2))
        self.seen = set()

    def forward(self, input_dict):
        h = self.body(input_dict["obs"])
        self.seen.add(h.dtype)
        return self.mu(h), self.logstd.expand(h.shape[0], 2), self.value(h), None


def _agent(mixed_precision):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update({"num_actors": 8, "horizon_length": 8, "minibatch_size": 32, "mini_epochs": 2,
                                    "learning_rate": 1e-3, "mixed_precision": mixed_precision})
    cfg = parse_params(raw, "cfg.yaml").config
    model = ActorCritic(MLP(), make_distribution("continuous_a2c_logstd", gym.spaces.Box(-1.0, 1.0, (2,)), False),
                        (3,), 1, False, False)
    return PPOAgent(model, cfg, CPU)


def _rollout(agent):
    storage = RolloutStorage(8, 8, (3,), torch.float32, (2,), torch.float32, 4, 1, CPU)
    gen = torch.Generator().manual_seed(1)
    for t in range(8):
        obs = torch.randn(8, 3, generator=gen)
        with torch.no_grad():  # the rollout acts in float32
            params, values, _ = agent.model.evaluate(obs, (), None, 1, None)
        actions = torch.randn(8, 2, generator=gen)
        storage.add(t, obs, actions, agent.model.dist.log_prob(params, actions), values, params)
        storage.add_outcome(t, torch.randn(8, 1, generator=gen), torch.zeros(8, dtype=torch.bool),
                            torch.zeros(8, dtype=torch.bool))
    storage.advantages.copy_(torch.randn(8, 8, 1, generator=gen))
    storage.returns.copy_(torch.randn(8, 8, 1, generator=gen))
    return storage


def test_bf16_update_on_a_cpu_runs_the_network_in_bf16_and_the_losses_in_float32(monkeypatch):
    monkeypatch.setattr(precision, "cpu_has_bf16", lambda: True)  # the code path, whatever this CPU has
    fp32, bf16 = _agent(False), _agent("bf16")
    assert fp32.amp_dtype is None and bf16.amp_dtype is torch.bfloat16
    before = [p.detach().clone() for p in bf16.params]
    rollouts = _rollout(fp32), _rollout(bf16)
    fp32.model.a2c_network.seen.clear()
    bf16.model.a2c_network.seen.clear()
    out32, out16 = fp32.update(rollouts[0], 0.0), bf16.update(rollouts[1], 0.0)
    assert bf16.model.a2c_network.seen == {torch.bfloat16} and fp32.model.a2c_network.seen == {torch.float32}
    assert all(p.dtype == torch.float32 for p in bf16.params)  # master weights stay float32
    assert any(not torch.equal(a, b) for a, b in zip(before, bf16.params))  # it trained
    for key in ("a_loss", "c_loss", "entropy"):  # bf16 rounding only: close to the float32 update
        assert out16[key] == pytest.approx(out32[key], rel=0.05, abs=0.02), key
    assert out16["kl"] < 0.01  # the rollout's float32 log-probs against bf16 passes: no spurious KL
