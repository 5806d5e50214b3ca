"""The push-cube example (envpool PandaRobotiqPushCube-v1): ``train.py --config`` runs its JSON for an
epoch and logs a success rate; the shipped checkpoint nn/push_cube.pth plays. MetaWorld/Push-v3's
config trains an epoch and logs its success rate."""

import os
import runpy
import sys

import pytest

from rlchain import Runner
from tests.conftest import ROOT

pytestmark = pytest.mark.smoke

CONFIG = os.path.join(ROOT, "rlchain", "configs", "push_cube", "train_config.json")
CHECKPOINT = os.path.join(ROOT, "nn", "push_cube.pth")


def test_train_py_runs_the_push_cube_json(tmp_path, monkeypatch, capsys):
    """train.py's ``__main__`` in this process (a command's child would import envpool again, about 4 s of CPU;
    the plays below import it once for the module)."""
    pytest.importorskip("envpool")
    # the shipped JSON as written, with fewer envs and a short episode so that an episode ends in the epoch
    monkeypatch.setattr(sys, "argv", [os.path.join(ROOT, "train.py"), "--config", CONFIG,
                                      "params.config.max_epochs=1", f"params.config.train_dir={tmp_path}",
                                      "params.config.num_actors=4", "params.config.horizon_length=64",
                                      "params.config.minibatch_size=128",
                                      "params.config.env_config.max_episode_steps=32"])
    with pytest.raises(SystemExit) as stop:
        runpy.run_path(sys.argv[0], run_name="__main__")
    out = capsys.readouterr()
    assert stop.value.code == 0, out.err[-3000:]
    assert "epoch 1" in out.out and ("| success 0." in out.out or "| success 1." in out.out), out.out


def test_shipped_push_cube_checkpoint_plays():
    pytest.importorskip("envpool")
    result = Runner().load(CONFIG, ["params.config.env_config.max_episode_steps=100"]).play(
        checkpoint=CHECKPOINT, games=2, quiet=True)
    assert result.games == 2 and result.success_rate is not None  # the env reports info['success']


def test_metaworld_push_config_logs_success(tmp_path, capsys):
    pytest.importorskip("envpool")
    result = Runner().load(os.path.join(ROOT, "rlchain", "configs", "ppo_metaworld_push.yaml"), [
        f"params.config.train_dir={tmp_path}", "params.config.max_epochs=1", "params.config.num_actors=4",
        "params.config.horizon_length=64", "params.config.minibatch_size=128",
        "params.config.env_config.max_episode_steps=16"]).train()
    assert result.epoch == 1
    assert "| success 0." in capsys.readouterr().out  # a random policy does not push the puck in 16 steps
