"""A config that asks for CUDA on a machine without it is the same run as the config with ``device: cpu``:
the same parsed config (so the same thread plan, no pinned memory, no CUDA graphs), one warning, and the
same training for the same seed."""

import copy
import dataclasses
import os
import warnings

import pytest
import torch

from rlchain import Runner
from rlchain.config.load import load_raw
from rlchain.parallel.device import on_available_device
from tests.conftest import BASE, CONFIGS

pytestmark = pytest.mark.smoke

RL_GAMES_CARTPOLE = os.path.join(CONFIGS, "rl_games", "ppo_cartpole.yaml")


def _without_device(raw):
    raw = copy.deepcopy(raw)
    raw["params"]["config"].pop("device", None)  # rl_games' default: cuda:0
    return raw


def _load(raw, overrides=()):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        params = Runner().load(raw, list(overrides)).params
    return params, [str(w.message) for w in caught if "CUDA is not available" in str(w.message)]


def test_rl_games_cartpole_without_device_parses_as_device_cpu(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    raw = load_raw(RL_GAMES_CARTPOLE)
    assert raw["params"]["config"]["device"] == "cpu"
    fallback, said = _load(_without_device(raw))
    cpu, quiet = _load(raw)
    assert fallback == cpu
    assert len(said) == 1 and "'cuda:0'" in said[0] and "training on cpu" in said[0] and not quiet


def test_tensor_env_device_falls_back_with_the_training_device(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    raw = load_raw(os.path.join(CONFIGS, "ppo_torch_cartpole.yaml"))
    overrides = ["params.config.device=cuda", "params.config.env_config.device=cuda"]
    params, said = _load(raw, overrides)
    assert params.config.device == "cpu" and params.config.env_config.get("device") == "cpu"
    assert len(said) == 1


def test_on_available_device_leaves_a_gpu_machine_alone():
    base = Runner().load(copy.deepcopy(BASE)).params
    asked = dataclasses.replace(base, config=dataclasses.replace(base.config, device="cuda:0"))
    assert on_available_device(asked, cuda_available=True) is asked
    assert on_available_device(base, cuda_available=False) is base
    with pytest.warns(UserWarning, match="CUDA is not available"):
        assert on_available_device(asked, cuda_available=False).config.device == "cpu"
    assert asked.config.device == "cuda:0"  # the argument is left as it is


def test_fallback_trains_the_same_run_as_device_cpu(monkeypatch, tmp_path):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    raw = load_raw(RL_GAMES_CARTPOLE)
    small = ["params.config.max_epochs=1", f"params.config.train_dir={tmp_path}", "params.config.score_to_win=1e9",
             "params.config.save_best_after=0"]
    results = []
    for config in (_without_device(raw), raw):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = Runner().load(config, small).train(seed=7)
        results.append((result.epoch, result.frames, result.mean_reward, result.best_reward))
    assert results[0] == results[1]
