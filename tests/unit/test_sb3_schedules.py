"""rlchain.sb3.schedules: SB3's ``fn(progress_remaining)`` schedules as live parameter changes."""

from types import SimpleNamespace

import pytest

from rlchain.sb3.schedules import ScheduleCallback, split_schedules


def test_schedules_are_split_from_their_value_at_the_start():
    given, schedules = split_schedules("ppo", {"learning_rate": lambda p: p * 1e-3, "clip_range": 0.2, "n_steps": 8})
    assert given == {"learning_rate": 1e-3, "clip_range": 0.2, "n_steps": 8}
    assert list(schedules) == ["learning_rate"]
    with pytest.raises(ValueError, match=r"^learning_rate: a schedule must return a number"):
        split_schedules("dqn", {"learning_rate": lambda p: "fast"})


def test_callback_sets_the_value_at_the_runs_progress():
    changes = []
    ctx = SimpleNamespace(state=SimpleNamespace(frames=300), set_params=lambda **kw: changes.append(kw))
    cb = ScheduleCallback("sac", {"learning_rate": lambda p: p * 1e-3}, start=100, total=800)
    cb.on_epoch_end(ctx, {}, None)  # 200 of 800 frames done: progress remaining 0.75
    assert changes == [{"actor_lr": 7.5e-4, "critic_lr": 7.5e-4, "alpha_lr": 7.5e-4}]
    ScheduleCallback("ppo", {"clip_range": lambda p: p * 0.2}, start=0, total=300).on_epoch_end(ctx, {}, None)
    assert changes[-1] == {"e_clip": 0.0}
