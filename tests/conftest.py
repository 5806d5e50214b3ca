"""Shared test helpers: repository paths and a tiny config factory."""

import copy
import os
import sys

import pytest
import torch

from rlchain import Runner
from rlchain.algos.ppo.ppo import PPO
from rlchain.models.build import build_env, build_model
from rlchain.registry import scoped_registrations
from rlchain.runs.logging import TrainLogger
from rlchain.training.loop import Loop

# One intra-op thread, as the Runner sets on a 2-core machine: tests that build models directly
# (not through the Runner) would otherwise spin 2 OpenMP threads beside envpool / Ray workers.
torch.set_num_threads(1)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIGS = os.path.join(ROOT, "rlchain", "configs")
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

BASE = {
    "params": {
        "seed": 1,
        "algo": {"name": "a2c_discrete"},
        "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [16]}},
        "config": {"name": "t", "env_name": "CartPole-v1", "device": "cpu", "num_actors": 4,
                   "horizon_length": 8, "minibatch_size": 16, "mini_epochs": 1},
    }
}


@pytest.fixture
def scoped_registries():
    """What the test registers (algos, models, networks, envs, vecenv types, log writers)
    is gone after it; what it replaced or unregistered is back."""
    with scoped_registrations():
        yield


@pytest.fixture
def base_config():
    """A fresh small valid CartPole config dict."""
    return copy.deepcopy(BASE)


def _signal_state() -> tuple:
    """SIGINT/SIGTERM handlers and the main thread's blocked signals: what a run may change only for its duration."""
    import signal

    handlers = tuple(signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM))
    return handlers, frozenset(signal.pthread_sigmask(signal.SIG_BLOCK, []))


@pytest.fixture(autouse=True)
def signal_state_is_restored():
    """Every test leaves the process's signal handling as it found it.

    A run, a library or a test that installs a handler or blocks a signal in the main thread and
    keeps it makes later signal tests depend on the order the suite runs in: this
    fixture names the test that leaked instead.
    """
    before = _signal_state()
    yield
    after = _signal_state()
    assert after == before, f"this test left the signal state changed: {before} -> {after}"


def ppo_epochs(config: str, overrides: list[str], num_envs: int, epochs: int) -> tuple[list[dict], PPO]:
    """Same-seed PPO epochs of ``config`` on a CPU, driven by hand (collect, then update): each update's stats and
    the trainer (rlchain.algos.ppo.ppo.PPO), its env closed."""
    params = Runner().load(config, overrides).params
    torch.manual_seed(0)
    env = build_env(params, num_envs, 0)
    model = build_model(params, env, torch.device("cpu"))
    ppo = Loop(params, PPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 0,
               {}).algorithm
    ppo.collector.place(torch.as_tensor(env.reset(seed=0)))
    out = []
    for _ in range(epochs):
        ppo.collect()
        out.append(ppo.update())
    env.close()
    return out, ppo
