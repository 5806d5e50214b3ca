"""What a newcomer reads: hints in the words they launched with, per-command --help, play without a checkpoint,
YAML syntax errors with their line and caret, the ETA by score_to_win."""

import os

import pytest

from rlchain import cli, console
from rlchain.config.errors import ConfigError
from rlchain.config.load import load_raw
from rlchain.log import set_dialect, train_hint
from rlchain.runs.progress import run_eta, score_eta
from tests.conftest import CONFIGS

CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")


@pytest.mark.parametrize(("dialect", "hint"), [
    ("rlchain", "rlchain train cfg.yaml --checkpoint runs/x/nn/last.pth"),
    ("runner.py", "python runner.py --train --file cfg.yaml --checkpoint runs/x/nn/last.pth"),
    ("python", "rlchain.Runner().load('cfg.yaml').train(checkpoint='runs/x/nn/last.pth')"),
])
def test_train_hint_speaks_the_launch_dialect(dialect, hint):
    previous = set_dialect(dialect)
    try:
        assert train_hint("cfg.yaml", "runs/x/nn/last.pth") == hint
        assert "<config>" in train_hint("<dict>")
    finally:
        set_dialect(previous)


def test_train_help_shows_the_train_options(capsys):
    with pytest.raises(SystemExit):
        console.main(["train", "ppo_cartpole", "--help"])
    out = capsys.readouterr().out
    assert out.startswith("usage: rlchain train NAME|PATH") and "--checkpoint" in out and "--seed" in out
    assert "--export" not in out and "--games" not in out and "-t, --train" not in out
    with pytest.raises(SystemExit):
        console.main(["tune", "--help"])
    assert capsys.readouterr().out.startswith("usage: rlchain tune SEARCH")


def test_play_without_a_checkpoint_is_an_error(capsys):
    assert console.main(["play", "ppo_cartpole"]) == 2
    err = capsys.readouterr().err
    assert "nothing to play without a checkpoint: rlchain play NAME|PATH --checkpoint CKPT" in err
    assert "--untrained" in err and "runner.py" not in err
    assert console.main(["play"]) == 2
    assert "a checkpoint is required: rlchain play NAME|PATH --checkpoint CKPT" in capsys.readouterr().err
    assert cli.main(["--play", "--file", CARTPOLE]) == 2
    assert "python runner.py --play --file CONFIG --checkpoint CKPT" in capsys.readouterr().err


def test_untrained_play_is_explicit_and_warned():
    with pytest.warns(UserWarning, match="no checkpoint: playing an untrained"):
        assert console.main(["play", "ppo_cartpole", "--untrained", "--games", "1",
                             "params.config.player.print_stats=false"]) == 0


def test_yaml_syntax_error_keeps_line_and_caret(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("params:\n  config:\n    name: x\n    gamma: [0.99\n    tau: 0.95\n")
    with pytest.raises(ConfigError) as err:
        load_raw(str(path))
    head, line, caret = str(err.value).split("\n")
    assert head.startswith(f"{path}: cannot parse file: line 5, column 8:")
    assert line == "        tau: 0.95" and caret == "           ^"
    assert line[caret.index("^")] == ":"


def test_eta_by_score_to_win():
    assert score_eta([(0.0, 100.0), (10.0, 200.0)], 400.0) == pytest.approx(20.0)
    assert score_eta([(0.0, 200.0), (10.0, 150.0)], 400.0) is None  # not rising: not estimable
    assert score_eta([(0.0, 100.0)], 400.0) is None and score_eta([(0, 1), (1, 2)], float("inf")) is None
    assert score_eta([(0.0, 100.0), (10.0, 450.0)], 400.0) == 0.0
    # the epoch limit says 390 s, the reward's trend 20 s: the sooner stop is the ETA
    assert run_eta(10, 400, 5120, -1, 0, 0, 10.0, by_score=20.0) == pytest.approx(20.0)
    assert run_eta(10, 400, 5120, -1, 0, 0, 10.0) == pytest.approx(390.0)


def test_torchrun_hint_follows_the_dialect():
    from rlchain.log import torchrun_hint

    previous = set_dialect("rlchain")
    try:
        assert torchrun_hint("cfg.yaml").endswith("-m rlchain train cfg.yaml params.config.multi_gpu=True")
        set_dialect("runner.py")
        assert "runner.py --train --file cfg.yaml" in torchrun_hint("cfg.yaml")
    finally:
        set_dialect(previous)
