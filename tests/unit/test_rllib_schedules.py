"""RLlib's schedules as values (``lr=[[0, 1e-5], [1000000, 1e-4]]``, the migration guide's form): the value at a
timestep, the checks, and a PPO whose ``train()`` k updates with the value at the env steps sampled before it."""

import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.schedules import Schedules, pairs, value_at


def test_value_is_linear_between_pairs_and_the_last_after_them():
    s = pairs(PPOConfig(), "lr", [[0, 1e-5], [1000000, 1e-4]])
    assert value_at(s, 0) == 1e-5 and value_at(s, 500000) == pytest.approx(5.5e-5)
    assert value_at(s, 1000000) == value_at(s, 5e6) == 1e-4
    drop = pairs(PPOConfig(), "entropy_coeff", [[0, 0.05], [1000000, 0.1], [1000001, 0.0]])
    assert value_at(drop, 999999) == pytest.approx(0.1, abs=1e-6) and value_at(drop, 1000001) == 0.0


@pytest.mark.parametrize("bad, says", [([[10, 1e-3]], "first pair is at timestep 0"),
                                       ([[0, 1e-3], [0, 1e-4]], "timesteps increase"),
                                       ([1e-3, 1e-4], "list of \\[timestep, value\\] pairs")])
def test_a_bad_schedule_is_one_line_naming_the_key(bad, says):
    with pytest.raises(ConfigError, match=f"PPOConfig: lr: a schedule('s| is)? .*{says}|{says}"):
        Schedules(PPOConfig().training(lr=bad))


def test_starting_config_holds_the_values_at_zero():
    config = PPOConfig().training(lr=[[0, 1e-3], [100, 0.0]], entropy_coeff=[[0, 0.02], [100, 0.0]])
    sched = Schedules(config)
    start = sched.starting_config(config)
    assert start["lr"] == 1e-3 and start["entropy_coeff"] == 0.02 and config["lr"][0] == [0, 1e-3]
    assert sched.at(50) == {"learning_rate": pytest.approx(5e-4), "entropy_coef": pytest.approx(0.01)}
    assert not Schedules(PPOConfig())


def test_ppo_trains_with_the_value_at_the_steps_before_and_reports_the_next(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = (PPOConfig().environment("CartPole-v1").debugging(seed=0)
            .training(train_batch_size=64, minibatch_size=64, num_epochs=1,
                      lr=[[0, 1e-3], [128, 0.0]], entropy_coeff=[[0, 0.02], [128, 0.0]]).build_algo())
    learners, trained = [], []
    try:
        for _ in range(3):
            learners.append(algo.train()["learners"]["default_policy"])
            agent = algo._stepper.context.algorithm.agent
            trained += [agent.lr, agent.entropy_coef]  # what this train()'s update used
    finally:
        algo.stop()
    assert trained == pytest.approx([1e-3, 0.02, 5e-4, 0.01, 0.0, 0.0])
    # RLlib's Learner steps its schedulers after the update (at the env steps sampled so far, this iteration's
    # included) and logs the new value: each result reports the next train()'s value
    assert [r["curr_lr"] for r in learners] == pytest.approx([5e-4, 0.0, 0.0])
    assert [r["default_optimizer_learning_rate"] for r in learners] == [r["curr_lr"] for r in learners]  # 2.60's
    assert [r["curr_entropy_coeff"] for r in learners] == pytest.approx([0.01, 0.0, 0.0])
