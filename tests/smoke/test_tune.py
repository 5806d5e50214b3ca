"""Optuna search (tuning/optuna_search.py): a tiny CartPole search beats a bad learning rate and writes a runnable
config."""

import os

import pytest
import yaml

from tests.conftest import CONFIGS

pytest.importorskip("optuna", reason="pip install rlchain[tune]")

from rlchain.config import load_config  # noqa: E402
from rlchain.config.errors import ConfigError  # noqa: E402
from rlchain.runner import Runner  # noqa: E402
from rlchain.tuning.common import load_search
from rlchain.tuning.search import run_search  # noqa: E402

BASE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
EPOCHS = 30
FIXED = ["params.config.lr_schedule=None"]  # the adaptive schedule would rescue a bad learning rate


def _search(tmp_path, **extra):
    spec = {
        "base": BASE, "metric": "mean_reward", "direction": "maximize", "trials": 4,
        "max_epochs_per_trial": EPOCHS, "overrides": FIXED, "seed": 3,  # seed 3: trial 2 samples lr ~3.7e-3
        "pruner": {"n_startup_trials": 2, "n_warmup_steps": 10},
        # half of this range (below 1e-4) barely learns in 30 epochs
        "params": {"params.config.learning_rate": {"type": "loguniform", "low": 1e-6, "high": 1e-2},
                   "params.config.mini_epochs": {"type": "int", "low": 2, "high": 6}},
    }
    spec.update(extra)
    path = tmp_path / "search.yaml"
    path.write_text(yaml.safe_dump(spec))
    return str(path)


def test_search_beats_bad_lr_and_writes_runnable_config(tmp_path, capsys):
    runs = str(tmp_path / "runs")
    output = str(tmp_path / "best.yaml")
    best, path = run_search(_search(tmp_path), output=output, train_dir=runs)
    bad = Runner().load(BASE, FIXED + [f"params.config.max_epochs={EPOCHS}", "params.config.learning_rate=1e-6",
                                       "params.config.print_stats=false",
                                       f"params.config.train_dir={runs}"]).train()
    assert best > bad.mean_reward + 30, (best, bad.mean_reward)
    out = capsys.readouterr().out
    assert "best trial" in out and "trial  state" in out
    assert path == output and os.path.isfile(tmp_path / "best_trials.csv")
    params = load_config(path)  # runnable: the base config with the best values applied
    assert params.config.lr_schedule in (None, "None") and params.config.max_epochs == 400
    with open(path, encoding="utf-8") as fh:
        lr = yaml.safe_load(fh)["params"]["config"]["learning_rate"]
    assert params.config.learning_rate == pytest.approx(lr) and lr > 1e-5
    result = Runner().load(path, ["params.config.max_epochs=2", "params.config.print_stats=false",
                                  f"params.config.train_dir={runs}"]).train()
    assert result.epoch == 2


@pytest.mark.parametrize("change, match", [
    ({"metric": "reward"}, r"search.yaml: metric: 'reward' is not one of"),
    ({"trials": 0}, r"search.yaml: trials: expected an integer >= 1"),
    ({"params": {"params.config.learning_rate": {"type": "loguniform", "low": 0, "high": 1}}},
     r"search.yaml: params.params.config.learning_rate.low: must be > 0"),
    ({"params": {"params.config.gamma": {"type": "categorical"}}},
     r"search.yaml: params.params.config.gamma.choices: required"),
    ({"params": {"params.config.mini_epochs": {"type": "int", "low": 0, "high": 3}}},
     r"search.yaml: params.params.config.mini_epochs: value 0 is rejected"),
    ({"base": "missing.yaml"}, r"search.yaml: base: config file 'missing.yaml' not found"),
    ({"typo": 1}, r"search.yaml: typo: unknown key"),
])
def test_bad_search_file_is_one_line(tmp_path, change, match):
    path = _search(tmp_path, **change)
    with pytest.raises(ConfigError, match=match) as info:
        if "mini_epochs" in str(change):
            run_search(path, output=str(tmp_path / "x.yaml"), train_dir=str(tmp_path / "runs"))
        else:
            load_search(path)
    assert "\n" not in str(info.value)


def test_missing_optuna_is_one_line(monkeypatch):
    import builtins

    real = builtins.__import__

    def no_optuna(name, *args, **kwargs):
        if name == "optuna":
            raise ImportError("No module named 'optuna'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_optuna)
    from rlchain.tuning.common import import_optuna as _import_optuna
    with pytest.raises(ImportError, match=r"pip install rlchain\[tune\]"):
        _import_optuna()


def test_shipped_search_file_is_valid():
    spec = load_search(os.path.join(CONFIGS, "tune", "tune_cartpole.yaml"))
    assert spec.base == os.path.join(CONFIGS, "ppo_cartpole.yaml") and spec.trials >= 4
