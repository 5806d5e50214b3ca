"""Success rates end to end on TestGoalReach-v0 (gymnasium, info['success'] / info['is_success'] through
final_info): the epoch line, TensorBoard episodes/success_rate, evaluation, success_to_win, the Player."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke

CONFIG = os.path.join(CONFIGS, "ppo_test_goal_reach.yaml")


def small(tmp_path, epochs, *extra):
    return [f"params.config.max_epochs={epochs}", f"params.config.train_dir={tmp_path}", "params.config.num_actors=8",
            "params.config.horizon_length=16", "params.config.minibatch_size=128", "params.config.save_best_after=0",
            *extra]


def test_success_rate_logged_evaluated_and_played(tmp_path, capsys):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    result = Runner().load(CONFIG, small(tmp_path, 3, "params.config.success_to_win=inf",
                                         "params.config.evaluation={interval: 3, games: 4, num_envs: 2}")).train()
    assert result.epoch == 3
    out = capsys.readouterr()
    assert "| success 0." in out.out or "| success 1." in out.out
    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    rates = [e.value for e in events.Scalars("episodes/success_rate")]
    assert rates and all(0.0 <= r <= 1.0 for r in rates)
    assert len(events.Scalars("evaluation/success_rate")) == 1

    last = os.path.join(result.run_dir, "nn", "last_test_goal_reach.pth")
    played = Runner().load(CONFIG).play(checkpoint=last, games=6)
    assert played.success_rate is not None and len(played.successes) == 6
    text = capsys.readouterr().out
    assert "success rate:" in text and ("success yes" in text or "success no" in text)


def test_success_to_win_stops_and_is_success_key(tmp_path):
    """success_to_win 0 stops at the first epoch with finished episodes; the Dict env reports
    ``is_success``, which ``success_key: auto`` finds (its Dict obs are flattened)."""
    result = Runner().load(CONFIG, small(tmp_path, 20, "params.config.success_to_win=0.0",
                                         "params.config.env_config.goal_dict=True",
                                         "params.config.env_config.max_steps=5")).train()
    assert result.stop_reason == "success_to_win 0.0 reached" and result.epoch <= 2


def test_success_key_off_and_wrong_key_log_no_rate(tmp_path, capsys):
    for key in ("none", "no_such_key"):
        result = Runner().load(CONFIG, small(tmp_path, 2, f"params.config.success_key={key}",
                                             "params.config.success_to_win=0.0")).train()
        assert result.stop_reason == "max_epochs 2 reached"
    assert "| success" not in capsys.readouterr().out


def test_bad_success_mode_is_one_line_error(tmp_path):
    from rlchain.config.errors import ConfigError

    with pytest.raises(ConfigError, match=r"params.config.success_mode: 'first' is not one of"):
        Runner().load(CONFIG, ["params.config.success_mode=first"])


def test_bad_her_strategy_is_one_line_error():
    from rlchain.config.errors import ConfigError

    her = os.path.join(CONFIGS, "sac_her_fetch_reach.yaml")
    with pytest.raises(ConfigError, match=r"params.config.replay.her.strategy: 'random' is not one of"):
        Runner().load(her, ["params.config.replay.her.strategy=random"])
