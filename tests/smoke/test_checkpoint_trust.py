"""Checkpoints load as data: a real checkpoint with one extra object whose unpickling would run code (here: create
a marker file) is refused, with one line naming the file and the type, by every path that opens a checkpoint
(play, train --checkpoint, export, watch, a distillation teacher, Tune's stepper, the rl_games API); the opt-in
(--trust-checkpoint, params.config.trust_checkpoint) loads it. Every shipped checkpoint loads; a flipped bit is
an error naming the tensor.
"""

import glob
import os

import pytest
import torch

from rlchain import Runner
from rlchain.cli import main
from rlchain.config.errors import ConfigError
from rlchain.inference.watch import watch_and_evaluate
from rlchain.rl_games.algos_torch.torch_ext import load_checkpoint
from rlchain.runs import checkpoint as ckpt
from rlchain.tuning.epochs import EpochStepper
from tests.conftest import CONFIGS, ROOT

pytestmark = pytest.mark.smoke
SHIPPED = sorted(glob.glob(os.path.join(ROOT, "rlchain", "checkpoints", "*.pth"))
                 + glob.glob(os.path.join(ROOT, "tests", "data", "*.pth")))
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")


class Payload:
    """Unpickling this calls open(marker, 'w'): code from the file, visible as the marker appearing."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return open, (self.marker, "w")


@pytest.fixture
def evil(tmp_path):
    """The shipped cartpole checkpoint with a payload added; returns (path, marker)."""
    marker = str(tmp_path / "payload_ran")
    state = ckpt.load(os.path.join(ROOT, "rlchain", "checkpoints", "cartpole.pth"))
    path = str(tmp_path / "cartpole_evil.pth")
    torch.save({**state, "note": Payload(marker)}, path)
    return path, marker


def refused(exc_info, path):
    text = str(exc_info.value)
    assert path in text and "io.open" in text and "--trust-checkpoint" in text and "\n" not in text, text


def test_every_shipped_checkpoint_loads_as_data():
    assert len(SHIPPED) >= 6  # the six files under rlchain/checkpoints
    for path in SHIPPED:
        assert ckpt.load(path)["format"] == ckpt.FORMAT


def test_play_train_export_refuse_the_payload(evil, tmp_path):
    path, marker = evil
    runner = Runner().load(CARTPOLE, [f"params.config.train_dir={tmp_path / 'runs'}", "params.config.device=cpu"])
    with pytest.raises(ckpt.CheckpointError) as exc:
        runner.play(path, games=1, quiet=True)
    refused(exc, path)
    with pytest.raises(ckpt.CheckpointError) as exc:
        runner.train(checkpoint=path)
    refused(exc, path)
    assert not (tmp_path / "runs").exists()  # refused before any run folder
    with pytest.raises(ckpt.CheckpointError) as exc:
        runner.export(path, str(tmp_path / "out.onnx"))
    refused(exc, path)
    with pytest.raises(ckpt.CheckpointError) as exc:
        Runner().load_from_checkpoint(path)  # --play without --file reads the config from the checkpoint
    refused(exc, path)
    with pytest.raises(ckpt.CheckpointError) as exc:
        load_checkpoint(path)  # rl_games' torch_ext
    refused(exc, path)
    assert not os.path.exists(marker)


def test_cli_refuses_with_one_line_and_the_flag_loads_a_trusted_file(evil, capsys):
    path, marker = evil
    assert main(["--play", "--file", CARTPOLE, "--checkpoint", path, "--games", "1",
                 "params.config.device=cpu"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("checkpoint error: ") and "io.open" in err and len(err.splitlines()) == 1, err
    assert not os.path.exists(marker)
    assert main(["--play", "--file", CARTPOLE, "--checkpoint", path, "--games", "1", "--trust-checkpoint",
                 "params.config.device=cpu", "params.config.player.print_stats=false"]) == 0
    assert os.path.exists(marker)  # the opt-in ran the file's code, as documented


def test_the_config_key_loads_a_trusted_file(evil):
    path, marker = evil
    Runner().load(CARTPOLE, ["params.config.trust_checkpoint=true", "params.config.device=cpu",
                             "params.config.player.print_stats=false"]).play(path, games=1, quiet=True)
    assert os.path.exists(marker)


def test_watch_skips_the_payload(evil, tmp_path, capsys):
    path, marker = evil
    folder = tmp_path / "watched"
    folder.mkdir()
    os.replace(path, folder / "evil.pth")
    params = Runner().load(CARTPOLE, ["params.config.device=cpu"]).params
    scores = watch_and_evaluate(params, str(folder), games=1, poll_seconds=0.05, timeout=0.3)
    assert scores == []
    assert "refused" in capsys.readouterr().out
    assert not os.path.exists(marker)


def test_distill_teacher_and_distilled_student_refuse_the_payload(evil, tmp_path):
    path, marker = evil
    over = [f"params.config.train_dir={tmp_path / 'runs'}", "params.config.max_epochs=1"]
    with pytest.raises(ConfigError) as exc:  # named as the config key that points at it
        Runner().load(os.path.join(CONFIGS, "distill_cartpole_lstm.yaml"),
                      [*over, f"params.config.teacher_checkpoint={path}"]).train()
    refused(exc, path)
    with pytest.raises((ckpt.CheckpointError, ConfigError)) as exc:
        Runner().load(CARTPOLE, [*over, f"params.config.distilled_checkpoint={path}"]).train()
    refused(exc, path)
    assert not os.path.exists(marker)


def test_tune_stepper_refuses_the_payload(evil, tmp_path):
    path, marker = evil
    runner = Runner().load(CARTPOLE, [f"params.config.train_dir={tmp_path / 'runs'}", "params.config.max_epochs=3",
                                      "params.config.print_stats=false", "params.config.num_actors=2",
                                      "params.config.minibatch_size=32", "params.config.horizon_length=16"])
    with pytest.raises(ckpt.CheckpointError) as exc:  # a trial started from a checkpoint
        EpochStepper(runner, checkpoint=path).next_epoch()
    refused(exc, path)
    stepper = EpochStepper(runner)
    assert stepper.next_epoch() is not None  # parked after its first epoch
    try:
        with pytest.raises(ckpt.CheckpointError) as exc:  # PBT's exploit loads another trial's checkpoint
            stepper.load(path)
        refused(exc, path)
    finally:
        stepper.shutdown()
    assert not os.path.exists(marker)


def test_a_flipped_bit_names_the_tensor(tmp_path):
    weight = torch.linspace(-1, 1, 256)
    path = str(tmp_path / "c.pth")
    ckpt.save_atomic({"format": ckpt.FORMAT, "model": {"actor.weight": weight, "bias": torch.zeros(3)}}, path)
    assert torch.equal(ckpt.load(path)["model"]["actor.weight"], weight)
    raw = bytearray(open(path, "rb").read())
    at = bytes(raw).find(weight.numpy().tobytes())
    assert at > 0
    raw[at + 4 * 100 + 3] ^= 0x40  # an exponent bit of element 100
    with open(path, "wb") as fh:
        fh.write(raw)
    with pytest.raises(ckpt.CheckpointError, match=r"tensor 'model.actor.weight' does not match the checksum"):
        ckpt.load(path)


def test_a_checkpoint_without_checksums_still_loads(tmp_path):
    path = str(tmp_path / "old.pth")
    torch.save({"format": ckpt.FORMAT, "model": {"w": torch.ones(2)}}, path)  # as rlchain wrote before
    assert torch.equal(ckpt.load(path)["model"]["w"], torch.ones(2))


def test_every_shipped_checkpoint_carries_checksums():
    from rlchain.runs import digest

    shipped = sorted(glob.glob(os.path.join(ROOT, "rlchain", "checkpoints", "*.pth")))
    assert shipped
    for path in shipped:
        raw = torch.load(path, map_location="cpu", weights_only=False)  # our own files: read raw to see the key
        stored = raw.get(digest.KEY)
        assert isinstance(stored, dict) and stored.get("algorithm") == digest.ALGORITHM, \
            f"{path} has no checksums: rewrite it with rlchain.runs.checkpoint.save_atomic"
        assert set(stored["tensors"]) == {p for p, _ in digest.tensors(raw)}, path


def test_a_flipped_exponent_bit_in_a_shipped_checkpoint_is_one_line(tmp_path, capsys):
    source = os.path.join(ROOT, "rlchain", "checkpoints", "cartpole.pth")
    weight = next(v for v in ckpt.load(source)["model"].values() if v.numel() >= 64)
    raw = bytearray(open(source, "rb").read())
    at = bytes(raw).find(weight.numpy().tobytes())
    assert at > 0
    raw[at + 4 * 7 + 3] ^= 0x40  # an exponent bit: a weight of ~1e37, as the audit planted
    path = tmp_path / "cartpole.pth"
    path.write_bytes(raw)
    assert main(["--play", "--checkpoint", str(path), "--games", "1", "params.config.device=cpu"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "does not match the checksum saved with it" in err, err
