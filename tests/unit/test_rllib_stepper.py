"""The face's training thread (rlchain/rllib/stepper.py): an algorithm stopped before its first ``train()`` ends its
run at once, off-policy ones too (their epoch finishes before it takes a stop; it used to park after that epoch
for a ``train()`` that never came, and ``stop()`` waited out its 60 s join)."""

import time

import pytest


@pytest.mark.parametrize("algo", ["DQN", "SAC"])
def test_an_algorithm_stopped_before_training_ends_its_run(algo, tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.dqn import DQNConfig
    from rlchain.rllib.algorithms.sac import SACConfig

    monkeypatch.chdir(tmp_path)
    config = (DQNConfig().environment("CartPole-v1") if algo == "DQN" else SACConfig().environment("Pendulum-v1"))
    built = config.training(train_batch_size_per_learner=8, num_steps_sampled_before_learning_starts=8).reporting(
        min_sample_timesteps_per_iteration=16).rl_module(model_config={"fcnet_hiddens": [8]}).build_algo()
    start = time.time()
    built.stop()
    assert not built._stepper._thread.is_alive() and time.time() - start < 30
