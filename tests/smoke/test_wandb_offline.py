"""--track offline: the scalars the WandbWriter gets (as TrainLogger writes them) end up in the wandb run.

The offline run file (``offline-run-*/run-<id>.wandb``) is read back record by record: it is a
LevelDB-style log (7-byte ``:W&B`` header, 32 KiB blocks, chunks with a 7-byte crc/length/type
header) of ``wandb_internal_pb2.Record`` protobufs. wandb >= 0.19 ships no Python reader for it.
"""

import glob
import json
import os
import struct
import sys

import pytest

from rlchain.runs.wandb_logger import INSTALL_HINT, TrackingError, start_wandb

pytestmark = pytest.mark.smoke

BLOCK = 32768
FULL, FIRST, MIDDLE, LAST = 1, 2, 3, 4


def read_records(path):
    """The protobuf records of a .wandb file, in order."""
    from wandb.proto import wandb_internal_pb2 as pb

    with open(path, "rb") as fh:
        data = fh.read()
    assert data[:4] == b":W&B" and struct.unpack("<H", data[4:6])[0] == 0xBEE1, data[:7]
    records, pos, pending = [], 7, b""
    while pos + 7 <= len(data):
        left = BLOCK - pos % BLOCK
        if left < 7:  # block trailer: zero padding
            pos += left
            continue
        _crc, length, kind = struct.unpack("<IHB", data[pos:pos + 7])
        chunk = data[pos + 7:pos + 7 + length]
        pos += 7 + length
        if kind == 0:
            continue
        pending += chunk
        if kind in (FULL, LAST):
            record = pb.Record()
            record.ParseFromString(pending)
            records.append(record)
            pending = b""
    return records


def history_rows(records):
    """Each history record as {key: value} (nested keys joined with '/')."""
    rows = []
    for r in records:
        if r.WhichOneof("record_type") == "history":
            rows.append({"/".join(item.nested_key) or item.key: json.loads(item.value_json) for item in r.history.item})
    return rows


@pytest.fixture
def offline_env(tmp_path, monkeypatch):
    """WANDB_MODE=offline with every wandb folder inside tmp_path; wandb's service is shut down after."""
    wandb = pytest.importorskip("wandb")
    monkeypatch.setenv("WANDB_MODE", "offline")
    monkeypatch.setenv("WANDB_DIR", str(tmp_path / "wandb_dir"))
    for var in ("WANDB_CONFIG_DIR", "WANDB_CACHE_DIR", "WANDB_DATA_DIR", "WANDB_ARTIFACT_DIR"):
        monkeypatch.setenv(var, str(tmp_path / "wandb_home" / var.lower()))
    monkeypatch.setenv("WANDB_SILENT", "true")
    monkeypatch.delenv("WANDB_RUN_ID", raising=False)
    yield tmp_path
    wandb.teardown()  # the next wandb.setup reads the environment again


def test_offline_run_logs_the_tagged_scalars_and_config(offline_env):
    import wandb

    from rlchain.runs.writers import Step, WandbWriter

    tmp_path = offline_env
    summaries = tmp_path / "runs" / "cartpole_01" / "summaries"
    config = {"params": {"seed": 7, "config": {"name": "cartpole", "learning_rate": 0.001}}}
    writer = WandbWriter("rlchain-test", None, config, "cartpole_01", str(summaries))
    try:
        for epoch in range(3):
            writer.write({"rewards/step": 10.0 * epoch + 0.5, "losses/a_loss": 0.25 - epoch},
                         Step(512 * (epoch + 1), epoch + 1, 1.0))
    finally:
        writer.exit_code = 0
        writer.close()
    writer.run.finish()  # idempotent
    # finish() returns once the run is closed, but wandb's service process may still hold the run file's
    # records in its write buffer (about 1 run in 10 read a 7-byte file here); shutting the service down
    # flushes it, as the end of a training process does.
    wandb.teardown()

    runs = glob.glob(str(tmp_path / "wandb_dir" / "wandb" / "offline-run-*"))
    assert len(runs) == 1, runs
    files = glob.glob(os.path.join(runs[0], "run-*.wandb"))
    assert len(files) == 1
    records = read_records(files[0])

    run = [r.run for r in records if r.WhichOneof("record_type") == "run"]
    assert run and run[0].display_name == "cartpole_01" and run[0].project == "rlchain-test"
    saved = {u.key: json.loads(u.value_json) for u in run[0].config.update}
    assert saved["params"] == config["params"]

    rows = history_rows(records)
    rewards = [(row["global_step"], row["rewards/step"]) for row in rows if "rewards/step" in row]
    losses = [(row["global_step"], row["losses/a_loss"]) for row in rows if "losses/a_loss" in row]
    assert rewards == [(512, 0.5), (1024, 10.5), (1536, 20.5)]
    assert losses == [(512, 0.25), (1024, -0.75), (1536, -1.75)]


def test_wandb_dir_defaults_to_the_run_folder(offline_env, monkeypatch):
    tmp_path = offline_env
    monkeypatch.delenv("WANDB_DIR")
    summaries = tmp_path / "runs" / "pendulum_02" / "summaries"
    with start_wandb("rlchain-test", None, {"params": {}}, "pendulum_02", str(summaries)) as tracker:
        assert tracker.wandb_run.id  # the wandb run's attributes are reachable
    assert glob.glob(str(tmp_path / "runs" / "pendulum_02" / "wandb" / "offline-run-*"))


def test_init_failure_is_one_line(offline_env, monkeypatch):
    import wandb

    def refuse(**kwargs):
        raise wandb.errors.UsageError("No API key configured.\nUse `wandb login` to log in.")

    monkeypatch.setattr(wandb, "init", refuse)
    with pytest.raises(TrackingError) as err:
        start_wandb("rlchain-test", None, {}, "x", str(offline_env / "s"))
    assert str(err.value) == ("--track: wandb.init failed: No API key configured. Use `wandb login` to log in. "
                              "(run `wandb login`, or set WANDB_MODE=offline)")


def test_missing_wandb_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "wandb", None)  # import raises ImportError
    with pytest.raises(ImportError) as err:
        start_wandb("p", None, {}, "x", str(tmp_path / "s"))
    assert str(err.value) == INSTALL_HINT == "--track needs Weights & Biases: pip install rlchain[wandb]"
