"""rlchain/compare/files.py: run folders from others read within bounds by ``rlchain compare``: an event record's
length is checked against the file before it is read, config.yaml must be UTF-8 without aliases, a FIFO or a device
is refused without being opened, and symbolic links back into a walked folder are not followed. Each case is one
line and exit 2 (or, for the links, the usual table), each under an alarm so that a hang fails instead of waiting."""

import os
import shutil
import signal
import struct

import pytest

from rlchain.compare import cli
from rlchain.compare.files import CompareError, read_config, records, walk_files
from tests.unit.test_compare import make_run


@pytest.fixture(autouse=True)
def alarm():
    def hang(signum, frame):
        raise TimeoutError("no answer in 20 s")

    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def run(tmp_path):
    return make_run(str(tmp_path / "runs"), "ppo_26-07-00-00", [1.0, 2.0, 3.0], "ppo")


def event_file(run):
    folder = os.path.join(run, "summaries")
    return os.path.join(folder, next(f for f in os.listdir(folder) if f.startswith("events.out.tfevents.")))


def compare_fails(run, tmp_path, capsys, *parts, extra=()):
    assert cli.main([run, "--no-plot", "--out", str(tmp_path / "cmp"), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("rlchain compare: error: ") and len(err.splitlines()) == 1, err
    for part in parts:
        assert part in err, err
    return err


def test_a_record_claiming_more_than_the_file_is_refused_before_reading(run, tmp_path, capsys):
    from tensorboard.compat.tensorflow_stub.pywrap_tensorflow import masked_crc32c

    length = struct.pack("<Q", 2**40)
    with open(event_file(run), "ab") as fh:
        fh.write(length + struct.pack("<I", masked_crc32c(length)) + b"x" * 16)
    compare_fails(run, tmp_path, capsys, "claims 1099511627776 bytes, the file has 16 after its header")


def test_a_damaged_length_is_refused(run, tmp_path, capsys):
    with open(event_file(run), "ab") as fh:
        fh.write(struct.pack("<QI", 2**40, 0) + b"x" * 16)
    compare_fails(run, tmp_path, capsys, "has a damaged length")


def test_a_file_that_ends_inside_a_header_is_read_up_to_there(run, tmp_path):
    with open(event_file(run), "ab") as fh:
        fh.write(b"\x01\x02\x03")
    assert len(list(records(event_file(run)))) >= 4
    assert cli.main([run, "--no-plot", "--out", str(tmp_path / "cmp")]) == 0


def test_a_config_that_is_not_utf8_or_has_aliases_is_one_line(run, tmp_path, capsys):
    config = os.path.join(run, "config.yaml")
    with open(config, "wb") as fh:
        fh.write(b"params:\n  config:\n    name: \xff\xfe\n")
    compare_fails(run, tmp_path, capsys, f"{config}: not UTF-8 text (byte 28)", extra=["--label-by", "config"])
    with open(config, "w") as fh:
        fh.write("a: &a [1, 2]\nb: [*a, *a]\n")
    compare_fails(run, tmp_path, capsys, "YAML alias *a is not allowed")


@pytest.mark.parametrize("which", ["events", "config"])
def test_a_fifo_is_refused_without_being_opened(run, tmp_path, capsys, which):
    path = event_file(run) if which == "events" else os.path.join(run, "config.yaml")
    os.remove(path)
    os.mkfifo(path)
    compare_fails(run, tmp_path, capsys, f"{path}: a FIFO, not a file: refused")


def test_a_device_is_refused(tmp_path):
    if not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero")
    with pytest.raises(CompareError, match="a character device, not a file"):
        read_config("/dev/zero")


def test_symbolic_link_loops_are_not_followed(run, tmp_path, capsys):
    os.symlink(".", os.path.join(run, "a"))
    os.symlink(".", os.path.join(run, "b"))
    os.symlink("..", os.path.join(run, "summaries", "up"))
    found = list(walk_files(run))
    assert len([f for f in found if "tfevents" in f]) == 1, found
    assert cli.main([run, "--no-plot", "--out", str(tmp_path / "cmp")]) == 0
    assert "| ppo |" in capsys.readouterr().out


def test_a_linked_run_folder_is_still_read(run, tmp_path, capsys):
    elsewhere = str(tmp_path / "elsewhere")
    shutil.move(os.path.join(run, "summaries"), elsewhere)
    os.symlink(elsewhere, os.path.join(run, "summaries"))
    assert cli.main([run, "--no-plot", "--out", str(tmp_path / "cmp")]) == 0
