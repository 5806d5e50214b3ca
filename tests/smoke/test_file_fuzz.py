"""Fuzzing the readers of files from others, as tests/smoke/test_config_fuzz.py fuzzes configs: crafted SB3 archives
(their data JSON's fields set to values from the edge of each type, members replaced by random bytes, cut short,
left out, turned into links or into members that lie about their size) loaded with rlchain.PPO / SAC / DQN.load, and
crafted run folders (event files flipped, cut, extended with records of random lengths; config.yaml random bytes;
FIFOs; symbolic-link loops) given to ``rlchain compare``. Each case must load, or end as one clean error line naming
the file, within its alarm: never a traceback, a hang or a module imported. A new seed each run (printed with any
failure; RLCHAIN_FUZZ_SEED=<n> repeats it).
"""

import contextlib
import io
import json
import os
import random
import shutil
import signal
import struct
import sys
import time
import zipfile

import pytest

import rlchain
from rlchain.compare import cli
from rlchain.config.errors import ConfigError
from rlchain.runs.checkpoint import CheckpointError
from tests.crafted_archives import bomb, members_of, stored, write_zip
from tests.smoke.test_config_fuzz import nasty
from tests.unit.test_compare import make_run

pytestmark = pytest.mark.smoke
DATA = os.path.join(os.path.dirname(__file__), os.pardir, "data", "sb3")
ARCHIVES = {"ppo_cartpole.zip": "PPO", "ppo_pendulum.zip": "PPO", "sac_pendulum.zip": "SAC", "dqn_cartpole.zip": "DQN"}
SPACE_FIELDS = [":type:", "_shape", "shape", "low", "high", "dtype", "n", "nvec", "start"]


class Hang(Exception):
    pass


@contextlib.contextmanager
def alarm(seconds):
    def hang(signum, frame):
        raise Hang

    previous = signal.signal(signal.SIGALRM, hang)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def seed_and_rng():
    seed = int(os.environ.get("RLCHAIN_FUZZ_SEED") or random.SystemRandom().randrange(2**32))
    print(f"RLCHAIN_FUZZ_SEED={seed}")
    return seed, random.Random(seed)


def random_bytes(rng, most=400):
    return bytes(rng.randrange(256) for _ in range(rng.randrange(0, most)))


def crafted_archive(rng, src, path):
    """A copy of the archive ``src`` with one to three random changes; returns what was changed."""
    members = {m[0]: m for m in members_of(src)}
    data = json.loads(members["data"][1])
    changes = []
    for _ in range(rng.randrange(1, 4)):
        kind = rng.random()
        if kind < 0.45:  # a data field, or a space's field, set to a nasty value
            if rng.random() < 0.5:
                space = rng.choice(["observation_space", "action_space"])
                if isinstance(data.get(space), dict):
                    field = rng.choice(SPACE_FIELDS)
                    data[space][field] = nasty(rng)
                    changes.append(f"{space}.{field}")
                    continue
            key = rng.choice(list(data) + ["num_timesteps", "n_envs", "seed", "use_sde", "policy_kwargs"])
            data[key] = nasty(rng)
            changes.append(f"data.{key}")
        elif kind < 0.6:  # data replaced by random bytes or brackets
            text = random_bytes(rng) if rng.random() < 0.5 else \
                "".join(rng.choice('[]{},:"1 a') for _ in range(rng.randrange(1, 3000))).encode()
            members["data"] = stored("data", text)
            changes.append("data: random text")
            data = None
            break
        else:
            name = rng.choice([n for n in members if n != "data"] + ["rlchain_model.pt"])  # rlchain's own member too
            how = rng.choice(["random", "cut", "drop", "lie", "bomb"])
            if how == "random":
                members[name] = stored(name, random_bytes(rng, 4000))
            elif how == "cut" and name in members:
                members[name] = stored(name, members[name][1][: rng.randrange(0, len(members[name][1]) + 1)])
            elif how == "drop":
                members.pop(name, None)
            elif how == "lie":
                members[name] = bomb(name, 64 * 2**20, declared=rng.randrange(0, 5000))
            else:
                members[name] = bomb(name, 3 * 2**30)
            changes.append(f"{name}: {how}")
    if data is not None:
        members["data"] = stored("data", json.dumps(data).encode())
    write_zip(path, list(members.values()))
    return changes


def clean_line(exc, path):
    text = str(exc)
    return "\n" not in text and str(path) in text


def test_crafted_archives_load_or_are_one_clean_line(tmp_path, monkeypatch):
    marker = tmp_path / "imported"
    (tmp_path / "fuzz_payload.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    seed, rng = seed_and_rng()
    deadline, done = time.monotonic() + 20, 0
    while done < 60 and time.monotonic() < deadline:
        name = rng.choice(list(ARCHIVES))
        path = tmp_path / f"case{done}.zip"
        changes = crafted_archive(rng, os.path.join(DATA, name), path)
        problem = None
        try:
            with alarm(10):
                getattr(rlchain, ARCHIVES[name]).load(str(path))
        except Hang:
            problem = "no answer in 10 s"
        except (CheckpointError, ConfigError) as exc:
            problem = None if clean_line(exc, path) else f"not one line naming the file: {exc}"
        except BaseException as exc:  # what load let through: a traceback for the user
            problem = f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"
        assert problem is None, f"RLCHAIN_FUZZ_SEED={seed}, case {done} ({name}: {changes}): {problem}"
        assert not marker.exists() and "fuzz_payload" not in sys.modules
        done += 1
    assert done >= 5, f"RLCHAIN_FUZZ_SEED={seed}: only {done} cases in 20 s"


def clear(target):
    """Whatever is at ``target`` (a file, a FIFO, a folder, a link) removed."""
    if os.path.isdir(target) and not os.path.islink(target):
        shutil.rmtree(target)
    elif os.path.lexists(target):
        os.remove(target)


def crafted_run(rng, good, path):
    """A copy of the run folder ``good`` at ``path`` with one to three random changes; returns what was changed."""
    shutil.copytree(good, path)
    summaries = os.path.join(path, "summaries")
    events = os.path.join(summaries, next(f for f in os.listdir(summaries) if "tfevents" in f))
    config = os.path.join(path, "config.yaml")
    changes = []
    for _ in range(rng.randrange(1, 4)):
        kind = rng.choice(["flip", "cut", "records", "garbage", "config", "fifo", "loop", "dir"])
        changes.append(kind)
        if kind in ("flip", "cut", "records", "garbage") and not (os.path.isfile(events) and
                                                                  not os.path.islink(events)):
            continue
        if kind == "flip":
            blob = bytearray(open(events, "rb").read())
            for _ in range(rng.randrange(1, 6)):
                if blob:
                    blob[rng.randrange(len(blob))] = rng.randrange(256)
            open(events, "wb").write(bytes(blob))
        elif kind == "cut":
            blob = open(events, "rb").read()
            open(events, "wb").write(blob[: rng.randrange(0, len(blob) + 1)])
        elif kind == "records":  # records with valid length CRCs and random lengths and contents
            from tensorboard.compat.tensorflow_stub.pywrap_tensorflow import masked_crc32c

            with open(events, "ab") as fh:
                for _ in range(rng.randrange(1, 4)):
                    length = rng.choice([0, 1, 7, 100, 2**31, 2**40, 2**63, rng.randrange(2**64)])
                    head = struct.pack("<Q", length)
                    fh.write(head + struct.pack("<I", masked_crc32c(head)) + random_bytes(rng, 200))
        elif kind == "garbage":
            with open(events, "ab") as fh:
                fh.write(random_bytes(rng, 300))
        elif kind == "config":
            clear(config)
            with open(config, "wb") as fh:
                fh.write(random_bytes(rng) if rng.random() < 0.5 else
                         json.dumps({"params": {"config": {"name": nasty(rng)}}}).encode())
        elif kind == "fifo":
            target = rng.choice([events, config])
            clear(target)
            os.mkfifo(target)
        elif kind == "loop":
            where = rng.choice([path, summaries])
            with contextlib.suppress(FileExistsError):
                os.symlink(rng.choice([".", "..", path]), os.path.join(where, f"l{rng.randrange(5)}"))
        else:  # a folder where a file is expected
            target = rng.choice([config, os.path.join(summaries, "events.out.tfevents.0.fuzz")])
            clear(target)
            os.makedirs(target)
    return changes


def test_crafted_run_folders_compare_or_are_one_clean_line(tmp_path):
    good = make_run(str(tmp_path / "good"), "ppo_26-07-00-00", [1.0, 2.0, 3.0], "ppo")
    seed, rng = seed_and_rng()
    deadline, done = time.monotonic() + 20, 0
    while done < 40 and time.monotonic() < deadline:
        path = str(tmp_path / "runs" / f"case{done}_26-07-00-00")
        changes = crafted_run(rng, good, path)
        err, problem = io.StringIO(), None
        try:
            with alarm(10), contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                code = cli.main([path, "--no-plot", "--out", str(tmp_path / "cmp"), "--label-by",
                                 rng.choice(["name", "config"])])
        except Hang:
            problem = "no answer in 10 s"
        except BaseException as exc:
            problem = f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}"
        else:
            lines = [line for line in err.getvalue().splitlines() if line.strip()]
            if code == 2 and (len(lines) != 1 or not lines[0].startswith("rlchain compare: error: ")):
                problem = f"exit 2 with {err.getvalue()[-400:]}"
            elif code not in (0, 2):
                problem = f"exit {code}: {err.getvalue()[-400:]}"
        assert problem is None, f"RLCHAIN_FUZZ_SEED={seed}, case {done} ({changes}): {problem}"
        done += 1
    assert done >= 5, f"RLCHAIN_FUZZ_SEED={seed}: only {done} cases in 20 s"


def test_the_crafted_files_are_what_they_claim(tmp_path):
    path = write_zip(tmp_path / "b.zip", [bomb("m", 3 * 2**30)])
    assert zipfile.ZipFile(path).getinfo("m").file_size == 3 * 2**30 and os.path.getsize(path) < 4 * 2**20
