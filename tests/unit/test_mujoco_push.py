"""MuJoCoPushCube-v0 (rlchain/envs/backends/mujoco_push.py): EmbodiChain's contract, its starts, success test
and reward terms, and exact state round trips."""

import numpy as np
import pytest
import torch

pytest.importorskip("mujoco")

from rlchain.envs.backends.mujoco_push import HALF, RADIUS, MuJoCoPushCube  # noqa: E402


def test_contract_shapes_terms_and_starts():
    env = MuJoCoPushCube(8, min_start_distance=0.15, seed=0)
    obs, info = env.reset(seed=0)
    assert set(obs) == {"object", "robot"} and obs["robot"]["ee_pos"].shape == (8, 2)
    _, _, cube, _, _ = env._parts()
    assert (np.abs(cube) <= 0.2).all() and (np.abs(env.goal) <= 0.3).all()
    assert (np.linalg.norm(env.goal - cube, axis=1) >= 0.15).all()
    obs, reward, terminated, truncated, info = env.step(torch.zeros(8, 2))
    assert reward.shape == (8,) and not terminated.any() and not truncated.any()
    assert set(info["rewards"]) == {"reaching_reward", "goal_distance_reward", "action_penalty", "success_bonus",
                                    "reach_progress", "goal_progress"}
    assert info["elapsed_steps"].tolist() == [1] * 8 and info["metrics"]["distance_to_goal"].shape == (8,)


def test_pushing_the_cube_onto_the_goal_succeeds_and_resets():
    env = MuJoCoPushCube(1, seed=0)
    env.reset(seed=0)
    q = env.q0
    env.state[0, q:q + 2] = (0.0, -(HALF + RADIUS + 0.01))  # the pusher just behind the cube, the goal ahead
    env.state[0, q + 2:q + 4] = (0.0, 0.0)
    env.goal[0] = (0.0, 0.2)
    steps = 0
    while steps < 40:
        _, reward, terminated, _, info = env.step(torch.tensor([[0.0, 1.0]]))
        steps += 1
        if terminated[0]:
            break
    assert info["success"][0] and 4 < steps < 40 and info["rewards"]["success_bonus"][0] == 1.0
    assert env.elapsed[0] == 0  # reset in the same step (no final observation in the contract)


def test_state_round_trip_replays_exactly():
    env = MuJoCoPushCube(4, seed=1)
    env.reset(seed=1)
    state = env.get_state()
    actions = torch.rand(5, 4, 2) * 2 - 1
    first = [env.step(a)[1] for a in actions]
    env.set_state(state)
    again = [env.step(a)[1] for a in actions]
    assert all(torch.equal(a, b) for a, b in zip(first, again))


def test_unknown_reward_term_is_an_error():
    with pytest.raises(ValueError, match="reward_weights: unknown term"):
        MuJoCoPushCube(1, reward_weights={"reach": 1.0})
