"""The envs' state for exact resume: gymnasium wrapper chains (frame stacks, normalization
filters, TimeLimit, np_random), an env holding what cannot be copied, the spec's capability flag and the
episode tracker's episodes in progress."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.base.episodes import EpisodeTracker
from rlchain.envs.spec import describe
from rlchain.envs.vecenv import StateUnavailable
from rlchain.envs.wrappers import gym_state


def wrapped_pendulum():
    env = gym.make("Pendulum-v1", max_episode_steps=7)
    env = gym.wrappers.NormalizeReward(gym.wrappers.NormalizeObservation(env))
    return gym.wrappers.FrameStackObservation(env, 3)


def rollout(env, steps, seed):
    actions = np.random.default_rng(seed).uniform(-2, 2, (steps, 1)).astype(np.float32)
    out = []
    for a in actions:
        obs, reward, terminated, truncated, _ = env.step(a)
        out.append(np.concatenate([np.ravel(obs), [reward, terminated, truncated]]))
        if terminated or truncated:
            out.append(np.ravel(env.reset()[0]))  # no seed: the env's own generator draws the next start
    return out


def same(a, b):
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def test_a_wrapped_gymnasium_env_continues_exactly_from_its_snapshot():
    a, b = wrapped_pendulum(), wrapped_pendulum()
    a.reset(seed=1)
    b.reset(seed=2)
    rollout(a, 5, 0)  # mid-episode: TimeLimit at 5 of 7, filters moved, three frames stacked
    gym_state.restore(b, gym_state.snapshot(a))
    # 20 steps cross the time limit twice: the reset draws from the restored np_random
    assert same(rollout(a, 20, 1), rollout(b, 20, 1))
    assert np.array_equal(a.get_wrapper_attr("obs_rms").mean, b.get_wrapper_attr("obs_rms").mean)


def test_a_snapshot_is_a_copy_not_a_view():
    env = wrapped_pendulum()
    env.reset(seed=0)
    state = gym_state.snapshot(env)
    mean = env.get_wrapper_attr("obs_rms").mean.copy()
    rollout(env, 3, 0)
    assert env.get_wrapper_attr("_elapsed_steps") == 3  # the env moved on ...
    restored = wrapped_pendulum()
    restored.reset(seed=5)
    gym_state.restore(restored, state)  # ... the snapshot did not
    assert restored.get_wrapper_attr("_elapsed_steps") == 0
    assert np.array_equal(restored.get_wrapper_attr("obs_rms").mean, mean)
    assert not np.array_equal(env.get_wrapper_attr("obs_rms").mean, mean)


class Handle:
    """Something an env holds that rlchain cannot read (an emulator, a physics engine)."""


class OpaqueEnv(gym.Env):
    observation_space = gym.spaces.Box(-1, 1, (1,))
    action_space = gym.spaces.Discrete(2)

    def __init__(self):
        self.engine = Handle()


def test_an_env_holding_an_unknown_object_is_unavailable_naming_it():
    with pytest.raises(StateUnavailable, match=r"env 3 \(OpaqueEnv\) holds 'engine' of type Handle, which "
                                               r"rlchain cannot snapshot"):
        gym_state.snapshot(OpaqueEnv(), "env 3")


def test_restoring_into_another_wrapper_chain_names_both():
    state = gym_state.snapshot(gym.make("Pendulum-v1"))
    with pytest.raises(ValueError, match=r"env: the saved env state is for layers \['TimeLimit'.*this env has "
                                         r"\['FrameStackObservation'"):
        gym_state.restore(wrapped_pendulum(), state)


class Inner:
    num_envs = 2

    def get_state(self):
        return {}

    def set_state(self, state):
        pass


class Forwarding:
    """A VecEnv wrapper that forwards unknown attributes: it must not lend the inner env's state."""

    num_envs = 2

    def __init__(self, env):
        self.env = env

    def __getattr__(self, name):
        return getattr(self.env, name)


def test_the_state_capability_is_the_class_declaring_both_methods():
    assert describe(Inner()).state
    assert not describe(Forwarding(Inner())).state
    assert not describe(type("OnlyGet", (), {"num_envs": 1, "get_state": lambda self: {}})()).state


def test_the_tracker_episodes_in_progress_round_trip():
    a = EpisodeTracker(3, 10, torch.device("cpu"))
    a.step(torch.tensor([1.0, 2.0, 3.0]), torch.tensor([False, True, False]), success=torch.tensor([1.0, np.nan, 0.0]))
    b = EpisodeTracker(3, 10, torch.device("cpu"))
    b.load_running_state(a.running_state())
    for tracker in (a, b):
        tracker.step(torch.ones(3), torch.tensor([True, True, True]))
    assert list(b.finished_returns) == [2.0, 1.0, 4.0] and list(b.finished_lengths) == [2, 1, 2]
    assert list(b.finished_successes) == [1.0, 0.0]  # env 0 succeeded at a step, env 2 reported a failure
    assert list(a.finished_returns)[1:] == list(b.finished_returns)
