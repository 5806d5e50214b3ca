"""RNN configs for a couple of epochs: train -> save -> play -> resume, and rl_games' own RNN config."""

import os

import pytest

from rlchain import Runner
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke
CONFIG = os.path.join(CONFIGS, "ppo_cartpole_masked_velocity_rnn.yaml")


def small(tmp_path, epochs, *extra):
    return [f"params.config.max_epochs={epochs}", f"params.config.train_dir={tmp_path}/runs",
            "params.config.print_stats=false", "params.config.num_actors=8", "params.config.horizon_length=32",
            "params.config.minibatch_size=128", "params.config.save_best_after=0", *extra]


@pytest.mark.parametrize("rnn", ["{name: lstm, units: 16}", "{name: gru, units: 16, layers: 2, before_mlp: True}",
                                 "{name: lstm, units: 16, concat_output: True, layer_norm: True}"])
@pytest.mark.parametrize("separate", [False, True])
def test_rnn_train_play_resume(tmp_path, rnn, separate):
    extra = (f"params.network.rnn={rnn}", f"params.network.separate={separate}")
    result = Runner().load(CONFIG, small(tmp_path, 2, *extra)).train()
    assert result.epoch == 2
    last = os.path.join(result.run_dir, "nn", "last_cartpole_masked_velocity_rnn.pth")
    played = Runner().load(CONFIG, list(extra)).play(last, games=2, quiet=True)
    assert played.games == 2
    resumed = Runner().load(CONFIG, small(tmp_path, 3, *extra)).train(checkpoint=last)
    assert resumed.epoch == 3
    assert ckpt.load(os.path.join(resumed.run_dir, "nn", "last_cartpole_masked_velocity_rnn.pth"))["epoch"] == 3


def test_rnn_with_continuous_actions(tmp_path):
    cfg = os.path.join(CONFIGS, "ppo_pendulum.yaml")
    extra = ["params.network.rnn={name: gru, units: 16}", "params.config.seq_length=8"]
    result = Runner().load(cfg, small(tmp_path, 2, *extra)).train()
    assert result.epoch == 2 and result.frames == 2 * 8 * 32


def test_rnn_checkpoint_exports_to_onnx(tmp_path, capsys):
    pytest.importorskip("onnxruntime")
    result = Runner().load(CONFIG, small(tmp_path, 1)).train()
    last = os.path.join(result.run_dir, "nn", "last_cartpole_masked_velocity_rnn.pth")
    out = Runner().load(CONFIG).export(last, os.path.join(tmp_path, "rnn.onnx"))
    assert os.path.isfile(out)
    line = [x for x in capsys.readouterr().out.splitlines() if "parity" in x][0]
    diffs = [float(x) for x in line.replace(",", " ").split() if "e-" in x or "e+" in x]
    assert diffs and max(diffs) < 1e-4, line


def test_rnn_with_truncated_bptt(tmp_path):
    extra = ("params.config.seq_length=8", "params.config.bptt_length=4")
    result = Runner().load(CONFIG, small(tmp_path, 2, *extra)).train()
    assert result.epoch == 2 and result.mean_reward > 0
