"""RLlib scripts run unmodified with ``python -m rlchain.rllib`` (rlchain/rllib/__main__.py): RLlib's own import
paths, a short training, checkpoints, inference, custom envs and callbacks; bad input ends in one line."""

import os
import subprocess
import sys

import pytest

pytest.importorskip("ray")

SCRIPTS = os.path.join(os.path.dirname(__file__), "rllib_scripts")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _run(script, tmp_path, *args):
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "rlchain.rllib", os.path.join(SCRIPTS, script), *args],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("script", ["getting_started.py", "custom_env.py"])
def test_rllib_script_runs_unmodified(script, tmp_path):
    out = _run(script, tmp_path, str(tmp_path / "ckpt"))
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.strip().endswith("OK")
    assert "stands in for RLlib" in out.stdout


@pytest.mark.parametrize("script, message", [
    ("bad_key.py", "PPOConfig.training(): num_epoch: not an RLlib config key; did you mean 'num_epochs'"),
    ("not_offered.py", "ray.rllib.core.learner is not offered by rlchain's RLlib face"),
])
def test_bad_input_ends_in_one_line(script, message, tmp_path):
    out = _run(script, tmp_path)
    assert out.returncode == 1
    assert out.stderr.strip().count("\n") == 0 and message in out.stderr, out.stderr


@pytest.mark.slow
def test_tuner_runs_ppo_by_name_on_real_ray_tune(tmp_path):
    """tune.Tuner("PPO", param_space=config) with a grid search: two trials on Ray Tune, each the face's PPO
    (a minute or more: Ray starts its processes)."""
    pytest.importorskip("ray.tune")
    out = _run("tune_ppo.py", tmp_path)
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
