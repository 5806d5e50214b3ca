"""Fuzzing the shipped ppo_cartpole.yaml and sac_pendulum.yaml: one key at a time set to a wrong, extreme or
meaningless value, and files that are not configs at all. Every case must end as a run (two tiny epochs) or
as one clean error line from the command line, never a traceback and never a hang (each case has a 20 s alarm).

Values that only make a valid run take long (mini_epochs: 10**9, a network of 10**9 units) are left out:
they are work the user asked for, not bad input the config can recognise.
"""

import contextlib
import io
import os
import signal

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
    path = mutated_file(tmp_path, key, value, base)
    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, 20)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(["--train", "--file", str(path)])
    except Hang:
        pytest.fail(f"{key}={value!r}: no answer in 20 s")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    lines = [line for line in err.getvalue().splitlines() if line.strip() and not line.startswith("warning:")]
    assert "Traceback" not in err.getvalue()
    if code == 0:
        return
    if len(lines) == 3 and lines[2].strip() == "^":  # a syntax error quotes its line, a caret under the column
        lines = lines[:1]
    assert code in (1, 2) and len(lines) == 1, err.getvalue()
    assert lines[0].split(":")[0] in ("config error", "checkpoint error", "env error", "error", "divergence",
                                      "network error"), lines[0]


def test_the_alias_and_the_seed_errors_say_what_is_wrong(tmp_path, capsys):
    path = mutated_file(tmp_path, None, "alias bomb")
    assert main(["--train", "--file", str(path)]) == 2
    assert "line 5: YAML alias *a is not allowed in a config" in capsys.readouterr().err
    assert main(["--train", "--file", BASE, "--seed", "-5"]) == 2
    assert "--seed: must be in 0 .. 2**32 - 1" in capsys.readouterr().err
