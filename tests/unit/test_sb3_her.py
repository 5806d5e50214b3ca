"""SB3's replay_buffer_class=HerReplayBuffer + replay_buffer_kwargs -> rlchain's config.replay.her."""

import enum

import pytest

from rlchain import HerReplayBuffer
from rlchain.sb3.her import her_config
from rlchain.sb3.keys import build_config


class GoalSelectionStrategy(enum.Enum):  # SB3's enum, by its member names
    FUTURE = 0
    FINAL = 1
    EPISODE = 2


def test_her_maps_its_kwargs():
    assert her_config(HerReplayBuffer, {"n_sampled_goal": 2, "goal_selection_strategy": "final"}) == \
        {"her": {"strategy": "final", "k": 2}}
    assert her_config(HerReplayBuffer, {"goal_selection_strategy": GoalSelectionStrategy.FUTURE}) == \
        {"her": {"strategy": "future", "k": 4}}
    assert her_config("HerReplayBuffer", None) == {"her": {"strategy": "future", "k": 4}}  # a saved model's name
    assert her_config(None, None) == {}


@pytest.mark.parametrize(("cls", "kwargs", "says"), [
    (HerReplayBuffer, {"goal_selection_strategy": "episode"}, "'episode' has no rlchain counterpart"),
    (HerReplayBuffer, {"n_sampled_goal": 0}, "n_sampled_goal: expected an int >= 1"),
    (HerReplayBuffer, {"online_sampling": True}, "online_sampling not known"),
    (dict, None, "replay_buffer_class: dict: rlchain's replay buffer is built in"),
    (None, {"n_sampled_goal": 4}, "replay_buffer_kwargs: given without"),
])
def test_what_does_not_map_is_one_line(cls, kwargs, says):
    with pytest.raises(ValueError, match=says):
        her_config(cls, kwargs)


def test_build_config_puts_her_in_the_replay_block():
    config = build_config("sac", "Goal-v0", 1, True, {"replay_buffer_class": HerReplayBuffer,
                                                      "replay_buffer_kwargs": {"n_sampled_goal": 3}}, [])
    assert config["params"]["config"]["replay"] == {"her": {"strategy": "future", "k": 3}}
