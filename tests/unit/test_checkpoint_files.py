"""runs/atomic.py, runs/digest.py and the data-only loading of runs/checkpoint.py, without a run."""

import collections
import errno
import os

import numpy as np
import pytest
import torch

from rlchain.runs import checkpoint as ckpt
from rlchain.runs import digest
from rlchain.runs.atomic import remove_stale_temps, write_atomic


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temp(tmp_path):
    path = tmp_path / "f.bin"
    path.write_bytes(b"old")

    def full(fh):
        fh.write(b"half")
        raise OSError(errno.ENOSPC, "No space left on device")
    with pytest.raises(OSError):
        write_atomic(str(path), full)
    assert path.read_bytes() == b"old" and os.listdir(tmp_path) == ["f.bin"]


def test_stale_temps_are_removed_and_nothing_else(tmp_path):
    for name in (".tmp_a.pth", ".tmp_b", "last_x.pth", "x.tmp_"):
        (tmp_path / name).write_bytes(b"x")
    removed = remove_stale_temps(str(tmp_path))
    assert sorted(os.path.basename(p) for p in removed) == [".tmp_a.pth", ".tmp_b"]
    assert sorted(os.listdir(tmp_path)) == ["last_x.pth", "x.tmp_"]


def test_digest_names_every_tensor_by_path_and_finds_a_change():
    state = {"model": {"a.weight": torch.ones(3), "b": torch.zeros(2, dtype=torch.bfloat16)},
             "agent": {"state": [torch.arange(4), (torch.tensor(True),)]}, "epoch": 3}
    saved = {**state, digest.KEY: digest.digest(state)}
    assert sorted(saved[digest.KEY]["tensors"]) == ["agent.state.0", "agent.state.1.0", "model.a.weight", "model.b"]
    assert digest.first_mismatch(saved) is None
    saved["model"]["b"][1] = 1.0
    assert digest.first_mismatch(saved) == "model.b"
    saved["model"]["b"][1] = 0.0
    del saved["agent"]
    assert digest.first_mismatch(saved) == "agent.state.0 (missing)"
    assert digest.first_mismatch(state) is None  # no checksums (an older checkpoint): not checked


def test_what_rlchain_writes_round_trips_as_data(tmp_path):
    from gymnasium.wrappers.utils import RunningMeanStd

    stats = RunningMeanStd(shape=(2,))
    stats.update(np.ones((3, 2)))
    state = {"format": ckpt.FORMAT, "rng": np.random.get_state(), "gen": np.random.default_rng(1).bit_generator.state,
             "frames": collections.deque([np.zeros(2, np.float32)], maxlen=4), "stats": stats,
             "scalars": [np.float32(1.5), np.int64(2), np.bool_(True), 1 + 2j, b"raw"],
             "model": collections.OrderedDict(w=torch.ones(2))}
    path = str(tmp_path / "c.pth")
    ckpt.save_atomic(state, path)
    out = ckpt.load(path)
    assert isinstance(out["frames"], collections.deque) and out["frames"].maxlen == 4
    assert np.array_equal(out["stats"].mean, stats.mean) and out["scalars"][:3] == [1.5, 2, True]
    assert out["rng"][0] == "MT19937" and np.array_equal(out["rng"][1], state["rng"][1])
    assert digest.KEY not in out


def test_read_takes_another_library_s_file_and_refuses_code(tmp_path):
    plain = tmp_path / "other.pth"
    torch.save({"model": {"w": torch.ones(1)}, "last_mean_rewards": np.float32(21.3)}, plain)
    assert ckpt.read(str(plain))["last_mean_rewards"] == np.float32(21.3)
    with pytest.raises(ckpt.CheckpointError, match="not an rlchain checkpoint"):
        ckpt.load(str(plain))
    code = tmp_path / "code.pth"
    torch.save({"f": os.getcwd}, code)
    with pytest.raises(ckpt.CheckpointError, match=r"refused: it names the type 'posix.getcwd'"):
        ckpt.read(str(code))
    assert ckpt.read(str(code), trusted=True)["f"] is os.getcwd


def test_the_folder_is_fsynced_after_the_rename(tmp_path, monkeypatch):
    from rlchain.runs import atomic

    synced = []
    real = os.fsync
    monkeypatch.setattr(atomic.os, "fsync", lambda fd: (synced.append(os.path.isdir(f"/proc/self/fd/{fd}")
                                                                      and os.readlink(f"/proc/self/fd/{fd}")),
                                                        real(fd)))
    write_atomic(str(tmp_path / "f"), lambda fh: fh.write(b"x"))
    assert synced[-1] == str(tmp_path)  # the file first, then its folder (the rename's entry)


class _Code:
    def __reduce__(self):
        return print, ("ran",)


@pytest.mark.parametrize("protocol", [4, 5])
def test_a_plain_pickle_is_named_without_torch_s_advice(tmp_path, protocol):
    import pickle

    for name, value in (("data", {"a": 1}), ("code", {"a": _Code()})):
        path = tmp_path / f"{name}.pkl"
        path.write_bytes(pickle.dumps(value, protocol=protocol))
        with pytest.raises(ckpt.CheckpointError) as exc:
            ckpt.read(str(path))
        text = str(exc.value)
        assert f"a plain Python pickle (protocol {protocol})" in text and "\n" not in text, text
        assert "weights_only" not in text and "arbitrary code" not in text, text


def test_an_empty_file_and_junk_say_so_plainly(tmp_path):
    empty, junk = tmp_path / "empty.pth", tmp_path / "junk.pth"
    empty.write_bytes(b"")
    junk.write_bytes(b"hello world")
    with pytest.raises(ckpt.CheckpointError, match=r"empty.pth: the file is empty \(0 bytes\)") as exc:
        ckpt.read(str(empty))
    assert "EOFError" not in str(exc.value)
    with pytest.raises(ckpt.CheckpointError, match="neither a zip archive .* nor a pickle"):
        ckpt.read(str(junk))


@pytest.mark.parametrize("env_name", ["CartPoleMaskedVelocity-v1", "CartPole-v1"])
def test_a_checkpoint_of_the_old_two_input_masked_cartpole_says_what_changed(env_name):
    model = torch.nn.Sequential(torch.nn.Linear(4, 8), torch.nn.Linear(8, 2))  # built for today's four inputs
    old = torch.nn.Sequential(torch.nn.Linear(2, 8), torch.nn.Linear(8, 2))
    state = {"model": old.state_dict(), "config": {"params": {"config": {"env_name": env_name}}}}
    expected = (r"^old\.pth: trained on CartPoleMaskedVelocity-v1 when it observed 2 inputs; the env now observes "
                r"4: .*velocities zeroed.*retrain on it, or play this file on an env of your own that keeps entries "
                r"0 and 2$") if env_name.startswith("CartPoleMasked") else r"parameter '0\.weight' has shape \(8, 2\)"
    with pytest.raises(ckpt.CheckpointError, match=expected) as info:
        ckpt.load_model_state(model, state, "old.pth")
    assert "\n" not in str(info.value)
