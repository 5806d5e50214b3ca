"""``algo.local_replay_buffer.get_state()``: rlchain's transition rows read back as RLlib's episodes (plain data)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.core.replay import ReplayBuffer
from rlchain.rllib.replay_buffer import LocalReplayBuffer, buffer_state
from rlchain.rllib.utils.serialization import gym_space_from_dict, gym_space_to_dict

OBS = gym.spaces.Box(-np.inf, np.inf, (3,), np.float32)
ACT = gym.spaces.Discrete(2)
LENGTHS = (3, 5)  # env 0's episodes end terminated after 3 steps, env 1's truncated after 5


def _fill(buffer: ReplayBuffer, steps: int) -> list[list[dict]]:
    """``steps`` vectorized steps of 2 envs into ``buffer``; each env's true episodes (obs, actions, rewards)."""
    episodes: list[list[dict]] = [[{"obs": [], "act": [], "rew": []}] for _ in LENGTHS]
    ep, t = [0, 0], [0, 0]
    for _ in range(steps):
        obs = torch.tensor([[e, ep[e], t[e]] for e in range(2)], dtype=torch.float32)
        act = torch.tensor([(ep[e] + t[e] + e) % 2 for e in range(2)])
        rew = torch.tensor([10.0 * ep[e] + t[e] + 0.5 * e for e in range(2)])
        nxt = torch.tensor([[e, ep[e], t[e] + 1] for e in range(2)], dtype=torch.float32)
        ends = [t[e] + 1 == LENGTHS[e] for e in range(2)]
        buffer.add(obs, act, rew, nxt, torch.tensor([ends[0], False]), torch.tensor([False, ends[1]]))
        for e in range(2):
            cur = episodes[e][-1]
            cur["obs"].append(obs[e].tolist())
            cur["act"].append(int(act[e]))
            cur["rew"].append(float(rew[e]))
            if ends[e]:
                cur["obs"].append(nxt[e].tolist())
                episodes[e].append({"obs": [], "act": [], "rew": []})
                ep[e], t[e] = ep[e] + 1, 0
            else:
                t[e] += 1
    for e in range(2):  # the running episode's last observation
        episodes[e][-1]["obs"].append([e, ep[e], t[e]])
    return episodes


def _by_key(state: dict) -> dict[tuple[int, int], dict]:
    out = {}
    for eps in state["episodes"]:
        obs = np.asarray(eps["observations"]["data"])
        out[(int(obs[0][0]), int(obs[0][1]))] = eps
    return out


@pytest.mark.parametrize("n_step, n_step_max", [(1, None), (3, None), (2, 4)])  # (2, 4): RLlib's range (2, 5)
def test_rows_become_rllibs_episodes(n_step: int, n_step_max: int | None) -> None:
    torch.manual_seed(0)
    buffer = ReplayBuffer(1000, (3,), (), num_envs=2, action_dtype=torch.long, n_step=n_step, gamma=0.9,
                          prioritized=True, n_step_max=n_step_max)
    truth = _fill(buffer, 12)
    state = buffer_state(buffer, OBS, ACT, steps_added=24, sampled=64)
    got = _by_key(state)
    expected = {(e, k): eps for e in range(2) for k, eps in enumerate(truth[e]) if eps["act"]}
    assert set(got) == set(expected)
    for key, eps in expected.items():
        mine = got[key]
        np.testing.assert_allclose(mine["observations"]["data"], eps["obs"])
        assert list(mine["actions"]["data"]) == eps["act"]
        np.testing.assert_allclose(mine["rewards"]["data"], eps["rew"], rtol=1e-5, atol=1e-4)
        assert mine["t"] == len(eps["act"]) and mine["t_started"] == 0
        done = len(eps["act"]) == LENGTHS[key[0]]
        assert mine["is_terminated"] == (done and key[0] == 0)
        assert mine["is_truncated"] == (done and key[0] == 1)
        assert len(mine["infos"]["data"]) == len(eps["obs"])
        assert gym_space_from_dict(mine["rewards"]["space"]) == gym.spaces.Box(-np.inf, np.inf, (), np.float32)
        assert gym_space_from_dict(mine["observations"]["space"]) == OBS
    # one index per stored row; every step is in an episode (rows plus the n - 1 pending ones)
    assert len(state["_indices"]) == len(buffer) == 24 - 2 * ((n_step_max or n_step) - 1)
    assert state["_num_timesteps"] == 24
    assert state["_num_timesteps_added"] == 24 and state["sampled_timesteps"] == 64
    leaves = state["_sum_segment"][buffer.tree.size:buffer.tree.size + len(buffer)]
    assert leaves.sum() == pytest.approx(state["_sum_segment"][1])
    assert dict(state["_tree_idx_to_sample_idx"]).keys() == set(range(len(buffer)))


def test_an_overwritten_episode_start_is_left_out() -> None:
    buffer = ReplayBuffer(16, (3,), (), num_envs=2, action_dtype=torch.long)  # 8 steps of 2 envs
    _fill(buffer, 13)
    state = buffer_state(buffer, OBS, ACT, steps_added=26, sampled=0)
    assert "_sum_segment" not in state  # uniform replay: EpisodeReplayBuffer's keys only
    for eps in state["episodes"]:
        obs = np.asarray(eps["observations"]["data"])
        assert obs[0][2] == 0  # every episode starts at its reset observation
        np.testing.assert_array_equal(obs[:, 2], np.arange(len(obs)))
    assert state["_num_timesteps"] < 16


def _plain(x: object) -> bool:
    """Data msgpack writes: str-keyed dicts, lists / tuples, numbers, strings, None, numeric numpy arrays."""
    if isinstance(x, dict):
        return all(isinstance(k, str) and _plain(v) for k, v in x.items())
    if isinstance(x, (list, tuple)):
        return all(_plain(v) for v in x)
    if isinstance(x, np.ndarray):
        return x.dtype.kind in "biuf"
    return x is None or isinstance(x, (bool, int, float, str))


def test_state_is_plain_data() -> None:
    buffer = ReplayBuffer(100, (3,), (), num_envs=2, action_dtype=torch.long, prioritized=True)
    _fill(buffer, 7)
    view = LocalReplayBuffer(buffer, OBS, ACT, 14, 0)
    state = view.get_state()
    assert _plain(state)
    assert len(view) == view.get_num_timesteps() == 14 and view.get_num_episodes() == len(state["episodes"])
    with pytest.raises(NotImplementedError, match="restore_from_path"):
        view.set_state(state)
    ormsgpack = pytest.importorskip("ormsgpack")  # what RLlib's callbacks page writes it with
    back = ormsgpack.unpackb(ormsgpack.packb(state, option=ormsgpack.OPT_SERIALIZE_NUMPY))
    assert back["_num_timesteps"] == 14 and len(back["episodes"]) == len(state["episodes"])


SPACES = [OBS, ACT, gym.spaces.MultiDiscrete([2, 3]), gym.spaces.MultiBinary(4),
          gym.spaces.Dict({"a": gym.spaces.Box(0, 1, (2,)), "b": gym.spaces.Discrete(3, start=1)}),
          gym.spaces.Tuple([ACT, gym.spaces.Box(-1, 1, (1,))])]


@pytest.mark.parametrize("space", SPACES)
def test_space_to_dict_round_trip(space: gym.spaces.Space) -> None:
    d = gym_space_to_dict(space)
    assert gym_space_from_dict(d) == space



def test_algorithm_hands_out_its_runs_buffer() -> None:
    from types import SimpleNamespace

    from rlchain.rllib.algorithm import Algorithm
    buffer = ReplayBuffer(100, (3,), (), num_envs=2, action_dtype=torch.long)
    _fill(buffer, 5)
    algo = Algorithm.__new__(Algorithm)  # the parts the property reads, without a run
    run = SimpleNamespace(buffer=buffer, agent=SimpleNamespace(updates=3))
    algo._stepper = SimpleNamespace(context=SimpleNamespace(algorithm=run, state=SimpleNamespace(frames=10)))
    algo.rlchain_config = {"params": {"config": {"batch_size": 32}}}
    algo.observation_space, algo.action_space = OBS, ACT
    view = algo.local_replay_buffer
    assert view.get_added_timesteps() == 10 and view.get_sampled_timesteps() == 96 and len(view) == 10
    algo._stepper.context.algorithm = SimpleNamespace(storage=None)  # PPO's run: no replay buffer, as in RLlib
    assert algo.local_replay_buffer is None


def test_get_state_copies_each_observation_once() -> None:
    """Linear in the rows, each observation copied once (into its episode's array): no per-row objects, no gather
    of the whole buffer before the episodes' own copies (on a 100k-row buffer that took ~13 CPU seconds)."""
    import tracemalloc

    rows, dim = 10_000, 256
    buffer = ReplayBuffer(rows, (dim,), (), action_dtype=torch.long, prioritized=True)
    buffer.obs.copy_(torch.randn(rows, dim))
    buffer.next_obs.copy_(torch.randn(rows, dim))
    buffer.terminated[49::50] = True  # episodes of 50 steps
    buffer.discounts.fill_(0.99)
    buffer.size, buffer.pos = rows, rows // 3
    space = gym.spaces.Box(-np.inf, np.inf, (dim,), np.float32)
    tracemalloc.start()
    try:
        state = buffer_state(buffer, space, ACT, rows, 0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    obs_bytes = rows * dim * 4
    assert sum(e["t"] for e in state["episodes"]) == rows - (50 - rows // 3 % 50)  # the overwritten start left out
    assert peak < 1.1 * obs_bytes + 600 * rows, (peak - obs_bytes) / rows  # + RLlib's per-row index entries
    first = state["episodes"][0]["observations"]["data"]
    assert not np.shares_memory(first, buffer.obs.numpy())
