"""The console a newcomer reads on a short run: `best` agrees between the epoch lines and the stop line, the
resume line reads as a sentence, and `rlchain tune` writes into its own run folder."""

import os
import re

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke

CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")


def test_best_is_the_same_on_epoch_and_stop_lines_and_resume_reads(tmp_path, capsys):
    small = ["params.config.max_epochs=4", f"params.config.train_dir={tmp_path}", "params.config.score_to_win=1e9",
             "params.config.progress.live=false"]
    result = Runner().load(CARTPOLE, small).train(seed=2)
    out = capsys.readouterr().out
    lines = re.findall(r"reward ([\d.]+) \| best ([\d.]+)", out)
    assert lines and all(float(best) >= float(reward) for reward, best in lines)
    stop = re.search(r"mean reward ([\d.]+), best ([\d.]+)", out)
    assert float(stop.group(2)) == pytest.approx(float(lines[-1][1]), abs=0.01)
    assert float(stop.group(2)) == pytest.approx(max(float(r) for r, _ in lines), abs=0.01)
    last = os.path.join(result.run_dir, "nn", "last_cartpole.pth")
    Runner().load(CARTPOLE, [*small, "params.config.max_epochs=5"]).train(checkpoint=last, seed=2)
    out = capsys.readouterr().out
    assert f"rlchain: resuming a2c_discrete on CartPole-v1 from {last} at epoch 4 (" in out


def test_tune_writes_its_best_config_into_its_run_folder(tmp_path, monkeypatch):
    pytest.importorskip("optuna", reason="pip install rlchain[tune]")
    import yaml

    from rlchain.tuning.search import run_search

    search = tmp_path / "search.yaml"
    search.write_text(yaml.safe_dump({
        "base": CARTPOLE, "metric": "mean_reward", "direction": "maximize", "trials": 1,
        "max_epochs_per_trial": 1, "seed": 1,
        "params": {"params.config.learning_rate": {"type": "loguniform", "low": 1e-4, "high": 1e-3}}}))
    monkeypatch.chdir(tmp_path)
    _, path = run_search(str(search), train_dir=str(tmp_path / "runs"))
    folder = os.path.dirname(path)
    assert os.path.dirname(folder) == str(tmp_path / "runs") and os.path.basename(folder).startswith("tune_")
    assert os.path.isfile(os.path.join(folder, "ppo_cartpole_best_trials.csv"))
    assert not [f for f in os.listdir(tmp_path) if f.endswith((".yaml", ".csv")) and f != "search.yaml"]
