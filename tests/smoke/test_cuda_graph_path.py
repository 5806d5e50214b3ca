"""cuda_graph's code path through real PPO runs on a CPU: the trainer forced onto it (the sync-free step with its
device-tensor lr and capturable Adam, the act-step wrapper; nothing is recorded off CUDA) learns what the eager
trainer does, and its checkpoints resume in an eager run and the other way round."""

import os

import pytest
import torch

from rlchain import Runner
from rlchain.algos.ppo import ppo as ppo_module
from tests.conftest import CONFIGS, ppo_epochs

pytestmark = pytest.mark.smoke

KEYS = ("a_loss", "c_loss", "entropy", "kl", "clip_frac", "grad_norm", "lr")
CONFIG = os.path.join(CONFIGS, "ppo_torch_pendulum.yaml")  # continuous: kl_reference previous, obs per minibatch


def _forced(monkeypatch):
    monkeypatch.setattr(ppo_module, "resolve_cuda_graph", lambda *args: True)


def _epochs() -> tuple[list[dict[str, float]], object]:
    overrides = ["params.config.num_actors=64", "params.config.minibatch_size=512", "params.config.print_stats=false"]
    return ppo_epochs(CONFIG, overrides, 64, 3)


def test_the_graph_path_learns_what_the_eager_path_does(monkeypatch):
    eager, eager_ppo = _epochs()
    assert not eager_ppo.agent.graphed and eager_ppo.collector.graphed_act is None
    _forced(monkeypatch)
    graphed, ppo = _epochs()
    assert ppo.agent.graphed and ppo.collector.graphed_act is not None
    for a, b in zip(eager, graphed):
        for key in KEYS:
            assert b[key] == pytest.approx(a[key], rel=1e-4, abs=1e-6), key


def _train(tmp_path, name, epochs, checkpoint=None):
    overrides = [f"params.config.train_dir={tmp_path}", f"params.config.full_experiment_name={name}",
                 f"params.config.max_epochs={epochs}", "params.config.num_actors=64",
                 "params.config.minibatch_size=512", "params.config.print_stats=false"]
    result = Runner().load(CONFIG, overrides).train(checkpoint=checkpoint)
    return os.path.join(result.run_dir, "nn", "last_torch_pendulum.pth")  # the config's name


def _optimizer_groups(path):
    state = torch.load(path, map_location="cpu", weights_only=False)
    found = []

    def walk(x):
        if isinstance(x, dict):
            if "param_groups" in x:
                found.extend(x["param_groups"])
            for v in x.values():
                walk(v)
    walk(state)
    return found


def test_graph_path_checkpoints_resume_eagerly_and_back(tmp_path, monkeypatch):
    with monkeypatch.context() as patch:
        _forced(patch)
        graphed = _train(tmp_path, "graphed", 3)
    groups = _optimizer_groups(graphed)
    assert groups and all(isinstance(g["lr"], float) and g["capturable"] is False for g in groups)
    resumed = _train(tmp_path, "eager_from_graphed", 5, graphed)  # an eager run loads it
    _forced(monkeypatch)
    again = _train(tmp_path, "graphed_from_eager", 7, resumed)
    assert os.path.exists(again)
