"""The off-policy loop's ``update_every``: ``num_updates_per_step`` updates after every ``update_every``-th
vectorized step of the run (SB3's train_freq, RLlib's sampling rounds), counted from the run's frames so an epoch
boundary or a resume keeps the rounds where they were."""

import os

import pytest

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.rllib.off_policy_results import last_target_update_frames
from tests.conftest import CONFIGS
from tests.unit.test_rllib_off_policy_results import _epoch_runner


def test_update_rounds_follow_every_nth_vectorized_step_across_epochs():
    algo, ctx = _epoch_runner(num_envs=2, steps=10, ups=3, warmup=0, every=5, update_every=4)
    stats, _, _ = algo._epoch()  # steps 1-10: rounds after steps 4 and 8
    assert stats["updates"] == 6 and algo.agent.moves == [16]  # update 5 in the round after step 8 (16 frames)
    stats, _, _ = algo._epoch()  # steps 11-20: rounds after 12, 16 and 20, not restarted by the epoch
    assert stats["updates"] == 9 and ctx.frames == 40
    assert algo.agent.moves == [16, 32, 40]  # updates 10 (the round at step 16) and 15 (at step 20)


def test_every_step_is_a_round_by_default():
    algo, _ = _epoch_runner(num_envs=2, steps=10, ups=3, warmup=0, every=5)
    stats, _, _ = algo._epoch()
    assert stats["updates"] == 30


def test_the_last_target_update_counts_rounds_of_update_every_steps():
    # 9 updates this epoch ending at 40 frames (2 envs, rounds every 4 steps = 8 frames, 3 updates each): update 15
    # was the last target update, in the round at 40 frames; with every 5 and 16 updates it would be 15 too
    assert last_target_update_frames(15, 9, 5, 3, 40, 2, update_every=4) == 40
    assert last_target_update_frames(16, 9, 5, 3, 42, 2, update_every=4) == 40  # an epoch ending between rounds
    assert last_target_update_frames(18, 9, 5, 3, 48, 2, update_every=4) == 40  # one round after it
    assert last_target_update_frames(15, 9, 5, 3, 30, 2) == 30  # update_every 1: as before


@pytest.mark.parametrize("value, says", [("0", "must be > 0, got 0"), ("two", "expected")])
def test_a_bad_update_every_is_a_one_line_error_naming_the_file_and_key(value, says):
    with pytest.raises(ConfigError, match=rf"dqn_cartpole.yaml: params.config.update_every: .*{says}") as err:
        Runner().load(os.path.join(CONFIGS, "dqn_cartpole.yaml"), [f"params.config.update_every={value}"])
    assert "\n" not in str(err.value)
