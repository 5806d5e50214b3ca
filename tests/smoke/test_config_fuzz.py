"""Fuzzing the shipped ppo_cartpole.yaml and sac_pendulum.yaml: one key at a time set to a wrong, extreme or
meaningless value, and files that are not configs at all. Every case must end as a run (two tiny epochs) or
as one clean error line from the command line, never a traceback and never a hang (each case has a 20 s alarm).

Values that only make a valid run take long (mini_epochs: 10**9, a network of 10**9 units) are left out:
they are work the user asked for, not bad input the config can recognise.
"""

import contextlib
import copy
import io
import os
import random
import signal
import time

import pytest
import yaml

from rlchain.cli import main
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke
BASE = os.path.join(CONFIGS, "ppo_cartpole.yaml")
SMALL = {"config.num_actors": 2, "config.horizon_length": 16, "config.minibatch_size": 32, "config.max_epochs": 2,
         "config.max_frames": 64, "config.print_stats": False, "config.device": "cpu", "network.mlp.units": [8],
         "torch_threads": 1, "update_threads": 1}
NAN = float("nan")
MUTATIONS = {
    "seed": [-5, 2**70, 2**32, "abc", 1.5],
    "config.horizon_length": [0, -1, 10**12, "abc", 1.5, None],
    "config.num_actors": [0, -3, 10**9, "x", []],
    "config.minibatch_size": [0, 7, 10**9, "x"],
    "config.mini_epochs": [0, -1, "x", 2.5],
    "config.learning_rate": [0, -1, 1e9, "x", NAN],
    "config.entropy_coef": [1e9, -1, "x"],
    "config.gamma": [1.5, -1, "x"],
    "config.tau": [2, -1],
    "config.e_clip": [0, -1, 1e9],
    "config.max_epochs": [0, -5, "x", 1.5],
    "config.max_frames": [0, "x"],
    "config.name": ["", "../../escape", ".hidden", "a/b", 5, None],
    "config.full_experiment_name": ["../x", "", "/abs"],
    "config.env_name": ["NoSuchEnv-v0", "", 5, None],
    "config.env_config": ["x", [1], {"nosuchkey": 1}],
    "config.device": ["tpu", "cuda:99", 5],
    "config.save_frequency": [-1, "x"],
    "config.games_to_track": [0, -1],
    "config.reward_shaper": ["x", {"scale_value": "x"}, {"nokey": 1}],
    "config.normalize_input": ["maybe", 5],
    "config.score_to_win": ["x", NAN],
    "network.mlp.units": [[], [0], [-1], "x", [64, 1.0e308], [1000000000000, 64]],
    "network.mlp.activation": ["nosuch", 5],
    "algo.name": ["nosuch", 5],
    "model.name": ["nosuch"],
    "config.callbacks": [["subprocess:Popen"], ["os:getcwd"], ["nosuchmodule:X"], "x"],
    "config.nosuchkey": [1],
    "nosuch": [1],
}
SAC = os.path.join(CONFIGS, "sac_pendulum.yaml")
SAC_SMALL = {"config.num_actors": 2, "config.num_steps_per_episode": 8, "config.num_warmup_frames": 16,
             "config.batch_size": 16, "config.replay_buffer_size": 64, "config.max_epochs": 2,
             "config.max_frames": 64, "config.print_stats": False, "network.mlp.units": [8],
             "torch_threads": 1, "update_threads": 1}
SAC_MUTATIONS = {
    "config.replay_buffer_size": [0, -1, 10**12, "x"],
    "config.batch_size": [0, 10**9],
    "config.num_steps_per_episode": [0, -1],
    "config.num_updates_per_step": [0, "x"],
    "config.actor_lr": [-1, 1e9],
    "config.critic_tau": [2, -1],
    "config.init_alpha": [0, -1],
    "network.log_std_bounds": [[2, -5], "x", [1]],
}
TEXTS = {
    "alias bomb": "params:\n  config:\n    env_config:\n      a: &a [x, x, x, x, x, x, x, x, x]\n"
                  "      b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]\n"
                  "      c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]\n",
    "a list": "params: [1, 2]\n",
    "empty": "",
    "binary": "\x00\x01\x02\xff garbage",
    "tabs": "params:\n\tconfig: {}\n",
    "unclosed": "params: {config: [1, 2\n",
    "random bytes": bytes(range(256)) * 4,  # not UTF-8
    "deep yaml": "params: " + "[" * 5000,
    "deep json": "[" * 100_000,  # written as cfg.json
    "deep yaml by indent": "params:\n" + "".join("  " * i + f"k{i}:\n" for i in range(1, 400)),
}


def cases():
    for base, mutations in ((BASE, MUTATIONS), (SAC, SAC_MUTATIONS)):
        for key, values in mutations.items():
            for value in values:
                yield pytest.param(base, key, value, id=f"{os.path.basename(base)}:{key}={value!r}")
    for name in TEXTS:
        yield pytest.param(BASE, None, name, id=name)


class Hang(Exception):
    pass


def set_key(raw, key, value):
    node = raw["params"]
    *path, last = key.split(".")
    for part in path:
        node = node.setdefault(part, {})
    node[last] = value


def mutated_file(tmp_path, key, value, base=BASE):
    path = tmp_path / ("cfg.json" if "json" in str(value) else "cfg.yaml")
    if key is None:
        text = TEXTS[value]
        path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
        return path
    with open(base, encoding="utf-8") as fh:
        raw = yaml.safe_load(fh)
    for small, v in (SMALL if base == BASE else SAC_SMALL).items():
        if small != key:
            set_key(raw, small, v)
    set_key(raw, "config.train_dir", str(tmp_path / "runs"))
    set_key(raw, key, value)
    path.write_text(yaml.safe_dump(raw), encoding="utf-8")
    return path


def _alarm(signum, frame):
    raise Hang


@pytest.mark.parametrize("base, key, value", list(cases()))
def test_a_mutated_config_is_a_run_or_one_clean_line(tmp_path, base, key, value):
    problem = one_clean_line(mutated_file(tmp_path, key, value, base), 20)
    assert problem is None, f"{key}={value!r}: {problem}"


def one_clean_line(path, seconds):
    """None when ``rlchain train path`` is a run or one clean error line within ``seconds``; else what went wrong."""
    # torch imports torch._dynamo at a process's first optimizer (seconds of CPU): imported here, before the
    # alarm is set, so that the alarm never goes off inside that import. An exception raised in the middle of
    # it leaves torch._dynamo half-imported for the rest of the process: every later torch.compile in this
    # test process fails ("module 'torch._dynamo.convert_frame' has no attribute 'convert_frame'", or a sympy
    # submodule missing, depending on where the import stopped).
    import torch._dynamo  # noqa: F401

    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(["--train", "--file", str(path)])
    except Hang:
        return f"no answer in {seconds} s"
    except BaseException as exc:  # what main() let through: a traceback for the user
        return f"{type(exc).__name__}: {exc}"[:500]
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    lines = [line for line in err.getvalue().splitlines() if line.strip() and not line.startswith("warning:")]
    if "Traceback" in err.getvalue():
        return err.getvalue()[-500:]
    if code == 0:
        return None
    if len(lines) == 3 and lines[2].strip() == "^":  # a syntax error quotes its line, a caret under the column
        lines = lines[:1]
    if code not in (1, 2) or len(lines) != 1:
        return f"exit {code}: {err.getvalue()[-500:]}"
    if lines[0].split(":")[0] not in ("config error", "checkpoint error", "env error", "error", "divergence",
                                      "network error"):
        return lines[0]
    return None


def test_the_alias_and_the_seed_errors_say_what_is_wrong(tmp_path, capsys):
    path = mutated_file(tmp_path, None, "alias bomb")
    assert main(["--train", "--file", str(path)]) == 2
    assert "line 5: YAML alias *a is not allowed in a config" in capsys.readouterr().err
    assert main(["--train", "--file", BASE, "--seed", "-5"]) == 2
    assert "--seed: must be in 0 .. 2**32 - 1" in capsys.readouterr().err


# ---- random configs: a new seed every run (RLCHAIN_FUZZ_SEED=n repeats one), printed with any failure ----
# keys whose large values only ask for long work (more epochs, updates, games) are left to the cases above
LONG_WORK = {"max_epochs", "max_frames", "mini_epochs", "games_num", "save_best_after", "score_to_win", "seed"}
NASTY_SCALARS = [0, -1, 1, 2, 3, 2**31, 2**63, -(2**70), 0.5, -0.0, 1e-320, 1e308, float("inf"), float("-inf"), NAN,
                 True, False, None, "", "x", "../..", "a\nb", "\x00", "\u00e9\u6f22", "cuda:9", "1e3", "null", "a:b",
                 "{", "[", "*a", "&a", "%", "nan"]


def nasty(rng, depth=0):
    """A random value that no key expects: scalars from the edge of each type, random text, nested containers."""
    kind = rng.random()
    if kind < 0.6 or depth >= 3:
        return rng.choice(NASTY_SCALARS) if rng.random() < 0.85 else \
            "".join(chr(rng.randrange(1, 0x3000)) for _ in range(rng.randrange(1, 12)))
    if kind < 0.8:
        return [nasty(rng, depth + 1) for _ in range(rng.randrange(0, 4))]
    return {rng.choice(["name", "x", "units", "", "1"]): nasty(rng, depth + 1) for _ in range(rng.randrange(0, 3))}


def leaf_keys(node, prefix=""):
    for key, value in node.items():
        path = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict) and value:
            yield from leaf_keys(value, path)
        else:
            yield path


def random_text(rng, small):
    """A file that is barely a config: random bytes, random brackets, a cut-off YAML (``small``: the small
    config, whose epoch limits come first so that a cut never leaves a long run)."""
    kind = rng.randrange(3)
    if kind == 0:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 400)))
    if kind == 1:
        return ("params: " + "".join(rng.choice("[]{},: x\n") for _ in range(rng.randrange(1, 3000)))).encode()
    config = small["params"]["config"]
    limits = {"max_epochs": 1, "max_frames": 64}
    small = {"params": {"config": {**limits, **{k: v for k, v in config.items() if k not in limits}},
                        **{k: v for k, v in small["params"].items() if k != "config"}}}
    text = yaml.safe_dump(small, sort_keys=False).encode()
    kept = text.index(b"max_frames: 64\n") + len(b"max_frames: 64\n")
    return text[: rng.randrange(kept, len(text))]


def test_random_configs_are_a_run_or_one_clean_line(tmp_path):
    seed = int(os.environ.get("RLCHAIN_FUZZ_SEED") or random.SystemRandom().randrange(2**32))
    rng = random.Random(seed)
    with open(BASE, encoding="utf-8") as fh:
        base = yaml.safe_load(fh)
    keys = [k for k in leaf_keys(base["params"]) if k.split(".")[-1] not in LONG_WORK]
    deadline = time.monotonic() + 20
    done = 0
    while done < 40 and time.monotonic() < deadline:
        path = tmp_path / f"case{done}.yaml"
        raw = copy.deepcopy(base)
        for small, v in SMALL.items():
            set_key(raw, small, v)
        set_key(raw, "config.max_epochs", 1)
        set_key(raw, "config.train_dir", str(tmp_path / "runs"))
        if rng.random() < 0.15:
            label = "random text"
            path.write_bytes(random_text(rng, raw))
        else:
            changes = {rng.choice(keys): nasty(rng) for _ in range(rng.randrange(1, 4))}
            for key, value in changes.items():
                set_key(raw, key, value)
            label = repr(changes)
            path.write_text(yaml.safe_dump(raw), encoding="utf-8")
        problem = one_clean_line(path, 10)
        assert problem is None, f"RLCHAIN_FUZZ_SEED={seed}, case {done} ({label[:300]}): {problem}"
        done += 1
    assert done >= 5, f"RLCHAIN_FUZZ_SEED={seed}: only {done} cases in 20 s"


def test_a_deeply_nested_override_is_one_line(capsys):
    assert main(["--train", "--file", BASE, "params.network.mlp.units=" + "[" * 5000]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("params.network.mlp.units: the value nests more than 64 levels deep") and "\n" not in err
