"""``algo.metrics.peek`` reads the result's counters, as RLlib's checkpoint guide compares a restored algorithm
with the one it was saved from (``cleanup()`` first, as the guide releases it)."""

import pytest

from rlchain.rllib.__main__ import explain
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.face_error import FaceNotOffered
from rlchain.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED_LIFETIME

KEY = (ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED_LIFETIME)


def _tiny():
    """CartPole PPO with 32 env steps a train(): every test here builds it."""
    return PPOConfig().environment("CartPole-v1").training(train_batch_size=32, minibatch_size=16, num_epochs=1)


def test_a_restored_algorithm_peeks_the_saved_ones_env_steps_and_iteration(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = _tiny().debugging(seed=1)
    algo = config.build_algo()
    assert algo.metrics.peek(KEY) is None  # nothing sampled yet
    algo.train()
    algo.train()
    path = algo.save_to_path(str(tmp_path / "ckpt"))
    algo.cleanup()
    assert algo.metrics.peek(KEY) == 64 and algo.iteration == 2  # still readable after cleanup, as in RLlib
    again = config.build_algo()
    try:
        again.restore_from_path(path)
        assert again.metrics.peek(KEY) == 64 and again.iteration == 2
        assert again.train()["env_runners"][NUM_ENV_STEPS_SAMPLED_LIFETIME] == 96
        assert again.metrics.peek(KEY) == 96
    finally:
        again.stop()


def test_a_logged_value_wins_over_the_results_under_the_same_key(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = _tiny().build_algo()
    try:
        algo.metrics.log_value("training_iteration", 7.0, reduce="max")
        algo.train()
        assert algo.metrics.peek("training_iteration") == 7.0
    finally:
        algo.stop()


def test_the_old_stacks_model_call_and_export_are_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = _tiny().build_algo()
    try:
        policy = algo.get_policy()  # RLlib's checkpoints/onnx_torch.py
        for call, says in ((lambda: policy.model({"obs": None}), "forward_inference"),
                           (lambda: policy.export_model("out", onnx=11), "torch.onnx.export")):
            with pytest.raises(FaceNotOffered) as info:
                call()
            assert says in explain(info.value) and "\n" not in explain(info.value)
        assert policy.compute_single_action([0.0, 0.0, 0.0, 0.0], explore=False)[0] in (0, 1)
    finally:
        algo.stop()
