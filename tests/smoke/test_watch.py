"""Checkpoint-folder evaluation (rlchain.inference.watch): rl_games' player.evaluation / dir_to_monitor."""

import os
import shutil
import threading
import time

import pytest

from rlchain.config.errors import ConfigError
from rlchain.inference.watch import watch_and_evaluate
from rlchain.runner import Runner
from tests.conftest import CONFIGS, ROOT

CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
QUIET = ["params.config.print_stats=false", "params.config.player.print_stats=false"]


def test_watch_evaluates_existing_then_new_checkpoints(tmp_path):
    Runner().load(CARTPOLE, QUIET + ["params.config.max_epochs=8", "params.config.save_best_after=2",
                                     f"params.config.train_dir={tmp_path}",
                                     "params.config.full_experiment_name=run"]).train()
    folder = tmp_path / "run" / "nn"
    existing = sorted(p for p in os.listdir(folder) if p.endswith(".pth"))
    assert existing, "training wrote no checkpoint"
    params = Runner().load(CARTPOLE, QUIET).params
    scores, errors = [], []

    def watch():
        try:
            watch_and_evaluate(params, str(folder), games=2, poll_seconds=0.05,
                               max_checkpoints=len(existing) + 1, timeout=60, on_result=scores.append)
        except Exception as exc:  # surfaced by the main thread
            errors.append(exc)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while len(scores) < len(existing) and time.monotonic() < deadline and not errors:
        time.sleep(0.05)
    assert not errors and len(scores) == len(existing)
    # a new checkpoint appears the way training writes one: complete, by rename
    shutil.copy(os.path.join(ROOT, "nn", "cartpole.pth"), folder / ".tmp_new.pth")
    os.replace(folder / ".tmp_new.pth", folder / "trained.pth")
    thread.join(timeout=60)
    assert not thread.is_alive() and not errors
    assert sorted(os.path.basename(s.path) for s in scores[:-1]) == existing
    assert os.path.basename(scores[-1].path) == "trained.pth" and scores[-1].result.games == 2
    assert scores[-1].result.mean_reward > max(s.result.mean_reward for s in scores[:-1])


def test_watch_stops_at_timeout_and_skips_foreign_files(tmp_path, capsys):
    (tmp_path / "junk.pth").write_bytes(b"not a checkpoint")
    params = Runner().load(CARTPOLE, QUIET).params
    start = time.monotonic()
    assert watch_and_evaluate(params, str(tmp_path), games=1, poll_seconds=0.05, timeout=0.3) == []
    assert time.monotonic() - start < 10
    assert "warning: skipping" in capsys.readouterr().out


def test_watch_needs_a_folder():
    with pytest.raises(ConfigError, match="player.dir_to_monitor: is required"):
        watch_and_evaluate(Runner().load(CARTPOLE).params, timeout=0)


def test_watch_settings_from_player_config(tmp_path):
    # player.evaluation, dir_to_monitor and update_checkpoint_freq are supported keys: a ConfigError here
    # is a regression and fails the test (it needs no optional dependency, so nothing to skip on)
    params = Runner().load(CARTPOLE, QUIET + ["params.config.player.evaluation=true",
                                              f"params.config.player.dir_to_monitor={tmp_path}",
                                              "params.config.player.update_checkpoint_freq=3"]).params
    assert params.config.player.evaluation and params.config.player.dir_to_monitor == str(tmp_path)
    shutil.copy(os.path.join(ROOT, "nn", "cartpole.pth"), tmp_path / "a.pth")
    scores = watch_and_evaluate(params, poll_seconds=0.05, max_checkpoints=1, timeout=30)
    assert len(scores) == 1 and scores[0].result.games == 3
