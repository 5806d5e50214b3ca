"""Run folders and the files in them: names are names (never paths), the folder stays inside train_dir, nothing
is written through a planted symlink, temp files of a killed writer are cleared, and a full disk (a writer
that raises ENOSPC) ends the run non-zero with the reason on its stop line instead of "successfully".
"""

import errno
import logging
import os
import re
import signal

import pytest
import torch

from rlchain import Runner
from rlchain.cli import main
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from rlchain.runs.atomic import write_text_atomic
from rlchain.runs.run_dir import create_run_dir
from rlchain.training.events import Callback
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
SMALL = ["params.config.num_actors=2", "params.config.horizon_length=16", "params.config.minibatch_size=32",
         "params.network.mlp.units=[8]", "params.config.print_stats=false", "params.config.score_to_win=1e9",
         "params.torch_threads=1", "params.update_threads=1"]


@pytest.mark.parametrize("key, value", [
    ("name", "../../../escaped"), ("name", "''"), ("name", ".hidden"), ("name", "a/b"), ("name", "a\\\\b"),
    ("full_experiment_name", "../x"), ("full_experiment_name", "/tmp/x"), ("full_experiment_name", "..")])
def test_a_run_name_that_is_a_path_is_a_config_error(tmp_path, key, value):
    with pytest.raises(ConfigError, match=rf"params\.config\.{key}: must") as exc:
        Runner().load(CARTPOLE, [f"params.config.{key}={value}", f"params.config.train_dir={tmp_path}"])
    assert "\n" not in str(exc.value)


@pytest.mark.parametrize("value", ["ab\ncd", "a\tb", "a\rb", "a\x1bb", "a\x00b"])
def test_a_run_name_with_a_control_character_is_a_config_error(tmp_path, value):
    for key in ("name", "full_experiment_name"):
        with pytest.raises(ConfigError, match=rf"params\.config\.{key}: must be printable") as exc:
            Runner().load({"params": {**yaml_params(), "config": {**yaml_params()["config"], key: value,
                                                                  "train_dir": str(tmp_path)}}})
        assert "\n" not in str(exc.value)
    assert list(tmp_path.iterdir()) == []


def test_train_dir_null_is_a_config_error_not_a_folder_named_none(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["--train", "--file", CARTPOLE, *SMALL, "params.config.max_epochs=1",
                 "params.config.train_dir=null"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("params.config.train_dir: expected a string, got null (leave the key out for its default)"), err
    assert not (tmp_path / "None").exists()


def yaml_params():
    import yaml

    with open(CARTPOLE, encoding="utf-8") as fh:
        return yaml.safe_load(fh)["params"]


def test_the_run_folder_is_checked_inside_train_dir(tmp_path):
    with pytest.raises(OSError, match="not a folder directly inside train_dir"):
        create_run_dir(str(tmp_path / "runs"), "x", "../outside", {})
    assert not (tmp_path / "outside").exists()


def test_no_file_is_written_through_a_planted_symlink(tmp_path):
    root = tmp_path / "runs" / "exp"
    (root / "nn").mkdir(parents=True)
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    os.symlink(victim, root / "config.yaml")
    (root / "nn" / ".tmp_abc123.pth").write_bytes(b"half a checkpoint")  # a writer killed mid-write
    run = create_run_dir(str(tmp_path / "runs"), "x", "exp", {"params": {"a": 1}})
    assert victim.read_text() == "keep me"
    assert not os.path.islink(root / "config.yaml") and "a: 1" in (root / "config.yaml").read_text()
    assert not (root / "nn" / ".tmp_abc123.pth").exists()
    os.symlink(victim, run.checkpoint("last"))  # a checkpoint path planted as a link: replaced, not followed
    ckpt.save_atomic({"format": ckpt.FORMAT}, run.checkpoint("last"))
    assert victim.read_text() == "keep me" and not os.path.islink(run.checkpoint("last"))
    write_text_atomic(str(root / "note.txt"), "x")
    assert sorted(p.name for p in root.iterdir()) == ["config.yaml", "nn", "note.txt", "summaries"]


def test_a_planted_nn_symlink_is_refused(tmp_path):
    root = tmp_path / "runs" / "exp"
    root.mkdir(parents=True)
    os.symlink(tmp_path, root / "nn")
    with pytest.raises(OSError, match="is a symlink"):
        create_run_dir(str(tmp_path / "runs"), "x", "exp", {})


def full_disk(monkeypatch, after=0, error=None):
    """torch.save writes some bytes then fails as a full disk does, from the (after+1)-th call on; ``error``:
    what it raises (default: OSError ENOSPC)."""
    calls = {"n": 0}
    real = torch.save

    def save(obj, fh, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] <= after:
            return real(obj, fh, *args, **kwargs)
        fh.write(b"\0" * 100)
        raise error or OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(torch, "save", save)


def leftovers(train_dir):
    return [f for _, _, files in os.walk(train_dir) for f in files if f.startswith(".tmp_")]


def test_a_full_disk_at_the_final_save_exits_non_zero_with_the_reason(tmp_path, monkeypatch, capsys):
    full_disk(monkeypatch)
    code = main(["--train", "--file", CARTPOLE, *SMALL, "params.config.max_epochs=2",
                 f"params.config.train_dir={tmp_path}"])
    err = capsys.readouterr().err
    assert code == 2, err
    line = [x for x in err.splitlines() if x.startswith("checkpoint error:")]
    assert len(line) == 1, err
    assert "stopped: max_epochs 2 reached at epoch 2" in line[0]
    assert "the final checkpoint was not written" in line[0] and "No space left on device" in line[0]
    assert "no checkpoint of this run exists" in line[0]
    assert leftovers(tmp_path) == []


def test_a_full_disk_after_some_saves_names_the_newest_kept(tmp_path, monkeypatch):
    full_disk(monkeypatch, after=2)  # epoch 1's periodic and last checkpoints are written, then the disk is full
    with pytest.raises(ckpt.CheckpointError, match=r"the newest checkpoint is .*last_cartpole\.pth \(epoch 1\)"):
        Runner().load(CARTPOLE, [*SMALL, "params.config.max_epochs=3", "params.config.save_frequency=1",
                                 f"params.config.train_dir={tmp_path}"]).train()
    assert leftovers(tmp_path) == []


def test_the_zip_writers_full_disk_error_is_one_stop_line_naming_the_newest_kept(tmp_path, monkeypatch, capsys):
    # what torch's zip writer raises when the disk fills mid-file: a RuntimeError, not an OSError
    error = RuntimeError("[enforce fail at inline_container.cc:603] . unexpected pos 4096 vs 4032")
    full_disk(monkeypatch, after=2, error=error)
    code = main(["--train", "--file", CARTPOLE, *SMALL, "params.config.max_epochs=3", "params.config.save_frequency=1",
                 f"params.config.train_dir={tmp_path}"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    lines = [x for x in err.splitlines() if x.strip() and not x.startswith("warning:")]
    assert len(lines) == 1 and lines[0].startswith("checkpoint error: stopped: max_epochs 3 reached"), err
    assert "RuntimeError: [enforce fail at inline_container.cc:603] . unexpected pos" in lines[0]
    assert re.search(r"the newest checkpoint is \S*last_cartpole\.pth \(epoch 1\)", lines[0]), lines[0]
    assert leftovers(tmp_path) == []


def test_sigterm_with_a_full_disk_says_nothing_was_kept(tmp_path, monkeypatch, caplog):
    class Term(Callback):
        def on_epoch_end(self, ctx, stats, episodes):
            os.kill(os.getpid(), signal.SIGTERM)

    full_disk(monkeypatch)
    with caplog.at_level(logging.INFO):
        result = Runner().load(CARTPOLE, [*SMALL, "params.config.max_epochs=5",
                                          f"params.config.train_dir={tmp_path}"]).train(callbacks=[Term()])
    assert result.stop_reason == "interrupted by SIGTERM"
    text = caplog.text
    assert "the final checkpoint was not written" in text and "no checkpoint of this run exists" in text, text
    assert "previous checkpoint is kept" not in text and "resume with" not in text


def test_a_resume_past_max_epochs_stops_at_once(tmp_path, caplog):
    over = [*SMALL, f"params.config.train_dir={tmp_path}"]
    first = Runner().load(CARTPOLE, [*over, "params.config.max_epochs=3"]).train()
    last = os.path.join(first.run_dir, "nn", "last_cartpole.pth")
    with caplog.at_level(logging.INFO):
        again = Runner().load(CARTPOLE, [*over, "params.config.max_epochs=2", "params.config.print_stats=true"]
                              ).train(checkpoint=last)
    assert again.epoch == 3 and again.frames == first.frames  # not one more epoch ("epoch 4/2")
    assert "max_epochs 2 reached (the checkpoint is at epoch 3; nothing to train)" in caplog.text


def test_the_csv_log_is_not_written_through_a_planted_symlink(tmp_path):
    root = tmp_path / "runs" / "exp" / "summaries"
    root.mkdir(parents=True)
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    os.symlink(victim, root / "scalars.csv")
    with pytest.raises(OSError, match="is a symlink"):
        Runner().load(CARTPOLE, [*SMALL, "params.config.max_epochs=1", f"params.config.train_dir={tmp_path / 'runs'}",
                                 "params.config.full_experiment_name=exp", "params.config.log_writers=[csv]"]).train()
    assert victim.read_text() == "keep me"


def test_a_full_disk_is_one_warning_then_a_count_at_the_end(tmp_path, monkeypatch, capsys):
    full_disk(monkeypatch, after=2)  # epoch 1's files are written; every write after fails
    with pytest.raises(ckpt.CheckpointError, match="the final checkpoint was not written"):
        Runner().load(CARTPOLE, [*SMALL, "params.config.max_epochs=6", "params.config.save_frequency=1",
                                 f"params.config.train_dir={tmp_path}"]).train()
    captured = capsys.readouterr()
    text = captured.out + captured.err
    failed = [line for line in text.splitlines() if "failed: No space left on device" in line]
    assert len([line for line in failed if line.startswith("warning: checkpoint writing")]) == 1, text
    count = [line for line in text.splitlines() if "checkpoint writes failed in this run" in line]
    # epochs 2-6 each fail ep_N and last, then the final save
    assert len(count) == 1 and count[0].startswith("warning: 11 checkpoint writes failed"), text
