"""benchmarks/peers/mjlab_peers.py without mjlab: batch geometry, the commands each system runs, the summary's seconds
to each peer's final reward, and its argument errors."""

import os

import pytest
import yaml

from benchmarks.peers import mjlab_peers
from tests.conftest import CONFIGS

GO1 = os.path.join(CONFIGS, "rl_games", "ppo_go1_velocity.yaml")


def test_fewer_envs_keep_the_number_of_minibatches():
    with open(GO1, encoding="utf-8") as fh:
        config = yaml.safe_load(fh)
    assert mjlab_peers.geometry(config, 4096) == {"num_actors": 4096, "horizon_length": 24, "minibatch_size": 24576,
                                                  "cv_minibatch_size": 24576}
    assert mjlab_peers.geometry(config, 16)["minibatch_size"] == 96  # 16 x 24 / 4


def test_each_system_gets_the_same_task_seed_device_and_envs(tmp_path):
    args = mjlab_peers.parse_args(["--config", GO1, "--systems", "rlchain_graph_on,rsl_rl", "--device", "cuda:1",
                                   "--envs", "64", "--epochs", "5", "--seed", "7"])
    shape = {"num_actors": 64, "horizon_length": 24, "minibatch_size": 384, "cv_minibatch_size": 384}
    ours = mjlab_peers.rlchain_command(args, shape, str(tmp_path), "True")
    assert {"--seed", "7", "params.config.device=cuda:1", "params.config.num_actors=64",
            "params.config.max_epochs=5", "params.config.cuda_graph=True"} <= set(ours)
    rsl = mjlab_peers.rsl_rl_command(args, "Mjlab-Velocity-Flat-Unitree-Go1", shape, str(tmp_path))
    for flag, value in (("--env.scene.num-envs", "64"), ("--agent.max-iterations", "5"), ("--agent.seed", "7"),
                        ("--gpu-ids", "1"), ("--agent.logger", "tensorboard")):
        assert rsl[rsl.index(flag) + 1] == value


def test_summary_gives_the_seconds_to_each_peers_final_reward():
    runs = [{"system": "rlchain", "returncode": 0, "seconds": 10.0, "points": [(2.0, 100, 1.0), (5.0, 200, 9.0)]},
            {"system": "rsl_rl", "returncode": 0, "seconds": 20.0, "points": [(8.0, 100, 2.0), (16.0, 200, 4.0)]}]
    args = mjlab_peers.parse_args(["--config", GO1, "--systems", "rlchain,rsl_rl"])
    text = mjlab_peers.summary(runs, args)
    assert "| rlchain | 9.00 | 200 | 10.0 | 20 | 0 |" in text
    assert "| rlchain | 5.0 | 5.0 |" in text  # its own final (9) at 5 s; rsl_rl's final (4) at 5 s
    assert "| rsl_rl | - | 16.0 |" in text  # rsl_rl never reaches 9


def test_bad_arguments_are_one_line_errors(capsys):
    with pytest.raises(SystemExit):
        mjlab_peers.parse_args(["--config", GO1, "--systems", "rlchain,sb3"])
    assert "unknown sb3" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        mjlab_peers.parse_args(["--config", GO1, "--systems", "rl_games2", "--rl-games-src", "/nowhere"])
    assert "rl_games 2.0 source checkout" in capsys.readouterr().err


SLEEPER = "import signal, time; signal.signal(signal.SIGINT, signal.default_int_handler); time.sleep(30)"
"""A run that outlasts its budget and stops on SIGINT, as a Python trainer does (also when the test itself was
started in the background, which leaves SIGINT ignored for its children)."""


def test_a_run_past_its_time_budget_is_cut_and_keeps_its_points(tmp_path, monkeypatch):
    import sys

    args = mjlab_peers.parse_args(["--config", GO1, "--systems", "rlchain", "--timeout", "0.5"])
    monkeypatch.setattr(mjlab_peers, "rlchain_command",
                        lambda *a: [sys.executable, "-c", SLEEPER])
    monkeypatch.setattr(mjlab_peers, "points", lambda *a: [(0.1, 10, 1.0)])
    run = mjlab_peers.train("rlchain", args, {}, {"num_actors": 4}, str(tmp_path))
    assert run["returncode"] == 124 and run["points"] == [(0.1, 10, 1.0)] and run["seconds"] < 20
