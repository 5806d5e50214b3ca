"""Shared test helpers: repository paths and a tiny config factory."""

import copy
import os
import sys

import pytest
import torch

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
def base_config():
    """A fresh small valid CartPole config dict."""
    return copy.deepcopy(BASE)
