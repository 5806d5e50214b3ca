"""Hindsight experience replay (algos/off_policy/her.py): goal layout, offsets, relabelled goals and rewards by hand."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.off_policy.her import HERReplayBuffer, future_offsets, goal_layout, relabel_probability
from rlchain.envs.wrappers.dict_obs import FlatDictBox
from rlchain.envs.wrappers.goal_env import fetch_compute_reward

BOX1 = gym.spaces.Box(-10, 10, (1,), np.float32)
# flat obs layout: [observation, achieved_goal, desired_goal] (one value each)
SPACE = FlatDictBox(gym.spaces.Dict({"observation": BOX1, "achieved_goal": BOX1, "desired_goal": BOX1}))


def sparse(achieved: torch.Tensor, desired: torch.Tensor) -> torch.Tensor:
    """0 when the goals are within 0.5, else -1 (the Fetch rule with threshold 0.5)."""
    return -((achieved - desired).abs().reshape(-1) > 0.5).float()


def test_goal_layout_from_flat_dict_space_and_errors():
    layout = goal_layout(SPACE)
    keys = list(SPACE.dict_space.spaces)
    assert layout.achieved == slice(keys.index("achieved_goal"), keys.index("achieved_goal") + 1)
    assert layout.desired == slice(keys.index("desired_goal"), keys.index("desired_goal") + 1)
    with pytest.raises(ValueError, match="needs Dict observations"):
        goal_layout(gym.spaces.Box(0, 1, (3,)))
    with pytest.raises(ValueError, match="missing desired_goal"):
        goal_layout(gym.spaces.Dict({"observation": BOX1, "achieved_goal": BOX1}))


def test_fetch_compute_reward_by_hand():
    achieved = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    desired = np.array([[0.03, 0.0, 0.04], [0.03, 0.0, 0.041], [1.0, 1.0, 1.0]])  # d = 0.05, 0.0508, 0
    np.testing.assert_array_equal(fetch_compute_reward(achieved, desired), [0.0, -1.0, 0.0])
    np.testing.assert_allclose(fetch_compute_reward(achieved, desired, reward_type="dense"),
                               [-0.05, -np.hypot(0.03, 0.041), 0.0], rtol=1e-6)


def test_future_offsets_and_relabel_probability():
    remaining = torch.tensor([0, 3, 3, 5])
    u = torch.tensor([0.9, 0.0, 0.99, 0.5], dtype=torch.float64)
    assert future_offsets(remaining, "future", u).tolist() == [0, 0, 3, 3]
    assert future_offsets(remaining, "final", u).tolist() == [0, 3, 3, 5]
    assert relabel_probability(4) == pytest.approx(0.8)


def _obs(x: float, goal: float) -> torch.Tensor:
    """One env's flat obs in SPACE's key order with observation = achieved goal = x."""
    parts = {"observation": x, "achieved_goal": x, "desired_goal": goal}
    return torch.tensor([parts[k] for k in SPACE.dict_space.spaces], dtype=torch.float32)


def _filled_buffer(strategy: str = "future", k: int = 4) -> HERReplayBuffer:
    """2 envs, goal 9 never reached. env 0 walks x = 1, 2, 3 (episode ends at step 3, truncated) then
    starts again at 10; env 1 walks x = -1, -2, -3, -4 and its episode stays open."""
    buf = HERReplayBuffer(64, (3,), (1,), goal_layout(SPACE), sparse, strategy=strategy, k=k, num_envs=2)
    for t in range(4):
        x0 = [0, 1, 2, 10][t]
        nx0 = [1, 2, 3, 11][t]
        obs = torch.stack([_obs(x0, 9.0), _obs(-t, 9.0)])
        nxt = torch.stack([_obs(nx0, 9.0), _obs(-t - 1, 9.0)])
        ended = torch.tensor([t == 2, False])
        buf.add(obs, torch.zeros(2, 1), torch.full((2,), -1.0), nxt, torch.zeros(2, dtype=torch.bool), ended)
    return buf


def test_episode_bookkeeping():
    buf = _filled_buffer()
    # slots: step t writes env 0 at 2t, env 1 at 2t + 1
    assert buf.slot_step.tolist()[:8] == [0, 0, 1, 1, 2, 2, 3, 3]
    assert buf.slot_end.tolist()[:8] == [2, -1, 2, -1, 2, -1, -1, -1]  # env 0's first episode closed at step 2
    assert buf.episode_start.tolist() == [3, 0] and buf.steps == 4


def test_relabelled_goals_and_rewards_by_hand():
    """Every relabelled goal is an achieved goal of the same episode at or after the transition, and the
    reward is recomputed for it; the rest keep goal 9 and reward -1."""
    torch.manual_seed(0)
    buf = _filled_buffer()
    a, d = buf.layout.achieved, buf.layout.desired
    # the goals each slot may take: its own and later next-state achieved goals in the episode
    allowed = {0: {1, 2, 3}, 2: {2, 3}, 4: {3}, 6: {11},                # env 0: episode 1 closed at step 2
               1: {-1, -2, -3, -4}, 3: {-2, -3, -4}, 5: {-3, -4}, 7: {-4}}  # env 1: open episode
    seen_relabel = 0
    for _ in range(20):
        batch = buf.sample(32)
        for i, slot in enumerate(batch["indices"].tolist()):
            goal = float(batch["obs"][i, d])
            assert float(batch["next_obs"][i, d]) == goal  # obs and next_obs get the same goal
            achieved = float(batch["next_obs"][i, a])
            if bool(batch["relabelled"][i]):
                seen_relabel += 1
                assert goal in allowed[slot]
                assert float(batch["rewards"][i]) == (0.0 if abs(achieved - goal) <= 0.5 else -1.0)
            else:
                assert goal == 9.0 and float(batch["rewards"][i]) == -1.0
    assert 0.7 < seen_relabel / (20 * 32) < 0.9  # k = 4: 80 %
    # the stored transitions are unchanged
    assert (buf.obs[:8, d] == 9.0).all() and (buf.rewards[:8] == -1.0).all()


def test_final_strategy_uses_the_last_achieved_goal():
    torch.manual_seed(1)
    buf = _filled_buffer("final", k=1000)
    batch = buf.sample(64)
    d = buf.layout.desired
    last = {0: 3, 2: 3, 4: 3, 6: 11, 1: -4, 3: -4, 5: -4, 7: -4}
    for i, slot in enumerate(batch["indices"].tolist()):
        if bool(batch["relabelled"][i]):
            assert float(batch["obs"][i, d]) == last[slot]
            # slot 4 (x 2 -> 3) and 6 (10 -> 11) and 7 reach their final goal: reward 0
            assert float(batch["rewards"][i]) == (0.0 if slot in (4, 6, 7) else -1.0)


def test_state_dict_round_trip_and_bad_settings():
    buf = _filled_buffer()
    fresh = HERReplayBuffer(64, (3,), (1,), buf.layout, sparse, num_envs=2)
    fresh.load_state_dict(buf.state_dict())
    assert fresh.slot_end.tolist() == buf.slot_end.tolist() and fresh.steps == 4
    with pytest.raises(ValueError, match="strategy"):
        HERReplayBuffer(8, (3,), (1,), buf.layout, sparse, strategy="episode")
    with pytest.raises(ValueError, match="n_step 1"):
        HERReplayBuffer(8, (3,), (1,), buf.layout, sparse, n_step=3)


def test_ring_wraps_keep_future_goals_in_the_same_episode():
    """A small ring (capacity 6, 2 envs, an episode of 5 steps): after wrapping, relabelled goals are
    still achieved goals of the sampled transition's own env and later step."""
    torch.manual_seed(2)
    buf = HERReplayBuffer(6, (3,), (1,), goal_layout(SPACE), sparse, num_envs=2)
    for t in range(5):
        obs = torch.stack([_obs(t, 9.0), _obs(100 + t, 9.0)])
        nxt = torch.stack([_obs(t + 1, 9.0), _obs(101 + t, 9.0)])
        buf.add(obs, torch.zeros(2, 1), torch.full((2,), -1.0), nxt, torch.zeros(2, dtype=torch.bool),
                torch.tensor([t == 4, t == 4]))
    batch = buf.sample(64)
    a, d = buf.layout.achieved, buf.layout.desired
    for i in range(64):
        if bool(batch["relabelled"][i]):
            start, goal = float(batch["next_obs"][i, a]), float(batch["obs"][i, d])
            assert (start >= 100) == (goal >= 100) and goal >= start
