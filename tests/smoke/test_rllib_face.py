"""RLlib scripts run unmodified with ``python -m rlchain.rllib`` (rlchain/rllib/__main__.py): RLlib's own import
paths, a short training, checkpoints, inference, custom envs and callbacks; bad input ends in one line."""

import os
import subprocess
import sys

import pytest

from tests.conftest import ROOT, installed
from tests.smoke.cli_server import run_python

# a mark, not pytest.importorskip at module level: that would import ray when the file is collected, in every
# pytest process (each xdist worker, the learning tier), whether or not a test of this file runs there
pytestmark = [pytest.mark.smoke, installed("ray")]
SCRIPTS = os.path.join(os.path.dirname(__file__), "rllib_scripts")


def _run(script, tmp_path, *args, fresh=False):
    """``python -m rlchain.rllib SCRIPT ARGS`` in ``tmp_path``: in a child of the fork server (it has imported torch
    and rlchain: tests/smoke/cli_server.py), or with ``fresh`` in a new process (a script that starts Ray's own
    processes)."""
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), "OMP_NUM_THREADS": "1"}
    argv = [sys.executable, "-m", "rlchain.rllib", os.path.join(SCRIPTS, script), *args]
    if fresh:
        return subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    return run_python(argv, tmp_path, env, 300)


@pytest.mark.parametrize("script", ["getting_started.py", "custom_env.py"])
def test_rllib_script_runs_unmodified(script, tmp_path):
    out = _run(script, tmp_path, str(tmp_path / "ckpt"))
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().endswith("OK")
    assert "stands in for RLlib" in out.stdout


@pytest.mark.parametrize("script, message", [
    ("bad_key.py", "PPOConfig.training(): num_epoch: not an RLlib config key; did you mean 'num_epochs'"),
    ("not_offered.py", "ray.rllib.core.learner.learner is not offered by rlchain's RLlib face: RLlib's Learner "
                        "subclasses are not run"),
])
def test_bad_input_ends_in_one_line(script, message, tmp_path):
    out = _run(script, tmp_path)
    assert out.returncode == 1
    assert out.stderr.strip().count("\n") == 0 and message in out.stderr, out.stderr


@pytest.mark.slow
def test_tuner_runs_ppo_by_name_on_real_ray_tune(tmp_path):
    """tune.Tuner("PPO", ...) and tune.Tuner(config.algo_class, ...) with a grid search: three trials on Ray Tune,
    each the face's PPO (a minute or more: Ray starts its processes)."""
    pytest.importorskip("ray.tune")
    out = _run("tune_ppo.py", tmp_path, fresh=True)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().endswith("OK")


def test_continuous_actions_train_and_infer_in_process(tmp_path, monkeypatch):
    """The one-line swap (no launcher) on Pendulum: a Gaussian policy, RLlib's action_dist_inputs layout
    (means then log-stds), actions inside the env's bounds."""
    import torch

    from rlchain.rllib.algorithms.ppo import PPOConfig

    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment("Pendulum-v1").env_runners(num_env_runners=1)
            .training(train_batch_size=256, minibatch_size=64, num_epochs=1).build_algo())
    try:
        result = algo.train()
        assert result["num_env_steps_sampled_lifetime"] == 256
        assert result["learners"]["default_policy"]["vf_loss"] <= 10.0  # vf_clip_param clamps each sample's loss
        inputs = algo.get_module().forward_inference({"obs": torch.zeros(3, 3)})["action_dist_inputs"]
        assert inputs.shape == (3, 2)
        action = algo.compute_single_action([1.0, 0.0, 0.0], explore=False)
        assert action.shape == (1,) and -2.0 <= float(action[0]) <= 2.0
    finally:
        algo.stop()


def test_dqn_trains_checkpoints_and_infers_in_process(tmp_path, monkeypatch):
    """DQNConfig on rlchain's DQN: iterations of min_sample_timesteps_per_iteration env steps, Q-values as the
    module's action_dist_inputs, a checkpoint that resumes the counters."""
    import torch

    from rlchain.rllib.algorithms.algorithm import Algorithm
    from rlchain.rllib.algorithms.dqn import DQNConfig

    monkeypatch.chdir(tmp_path)
    algo = (DQNConfig().environment("CartPole-v1").reporting(min_sample_timesteps_per_iteration=200)
            .training(num_steps_sampled_before_learning_starts=100, train_batch_size=16).build_algo())
    try:
        for _ in range(2):
            result = algo.train()
        assert result["num_env_steps_sampled_lifetime"] == 400
        assert result["learners"]["default_policy"]["qf_loss"] >= 0
        q = algo.get_module().forward_inference({"obs": torch.zeros(2, 4)})["action_dist_inputs"]
        assert q.shape == (2, 2) and algo.compute_single_action([0.0] * 4) in (0, 1)
        path = algo.save_to_path(str(tmp_path / "dqn"))
    finally:
        algo.stop()
    restored = Algorithm.from_checkpoint(path)
    try:
        assert restored.train()["num_env_steps_sampled_lifetime"] == 600
    finally:
        restored.stop()


def test_evaluate_plays_the_requested_episodes_and_steps(tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.ppo import PPOConfig

    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment("CartPole-v1").debugging(seed=3)
              .training(train_batch_size=256, minibatch_size=128, num_epochs=1).evaluation(evaluation_duration=3))
    algo = config.build_algo()
    try:
        algo.train()
        games = algo.evaluate()["env_runners"]
        assert games["num_episodes"] == 3 and games["episode_len_mean"] >= 8
        assert games["episode_return_mean"] == pytest.approx(games["episode_len_mean"])  # CartPole: 1 per step
        algo.config._settings.update(evaluation_duration=40, evaluation_duration_unit="timesteps")
        assert algo.evaluate()["env_runners"]["num_env_steps_sampled"] == 40
    finally:
        algo.stop()
