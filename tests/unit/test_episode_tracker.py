"""EpisodeTracker keeps ended episodes on the device and reads them on demand: the games, their order and
their success values are those of a plain per-env loop, with env groups, dropped rows and success values."""

import math
import random

import pytest
import torch

from rlchain.algos.base.episodes import EpisodeTracker


def _reference(steps, num_envs, mode):
    """A per-env Python loop over the same steps: (returns, lengths, successes) in the order games end."""
    ret, length = [0.0] * num_envs, [0] * num_envs
    seen, hit_any, hit_last = [False] * num_envs, [False] * num_envs, [False] * num_envs
    out_r, out_l, out_s = [], [], []
    for rows, rewards, dones, dropped, success in steps:
        for k, env in enumerate(range(num_envs)[rows]):
            ret[env] += rewards[k]
            length[env] += 1
            if success is not None and not math.isnan(success[k]):
                seen[env] = True
                hit_any[env] |= success[k] > 0.5
                hit_last[env] = success[k] > 0.5
            lost = dropped is not None and dropped[k]
            if dones[k] and not lost:
                out_r.append(ret[env])
                out_l.append(length[env])
                if seen[env]:
                    out_s.append(float(hit_any[env] if mode == "any" else hit_last[env]))
            if dones[k] or lost:
                ret[env], length[env] = 0.0, 0
                seen[env] = hit_any[env] = hit_last[env] = False
    return out_r, out_l, out_s


@pytest.mark.parametrize("cheap_sync", [True, False])  # False: the GPU's path, every step kept on the device
def test_the_tracker_records_what_a_per_env_loop_records(cheap_sync):
    rng = random.Random(3)
    num_envs = 6
    groups = [slice(0, 3), slice(3, 6), slice(None)]
    steps = []
    for t in range(200):
        rows = groups[t % 3]
        n = len(range(num_envs)[rows])
        rewards = [rng.uniform(-1, 1) for _ in range(n)]
        dones = [rng.random() < 0.2 for _ in range(n)]
        dropped = [rng.random() < 0.05 for _ in range(n)] if t % 7 == 0 else None
        success = None if t < 20 else [rng.choice([math.nan, 0.0, 1.0]) for _ in range(n)]
        steps.append((rows, rewards, dones, dropped, success))
    for mode in ("any", "last"):
        tracker = EpisodeTracker(num_envs, 10_000, torch.device("cpu"), success_mode=mode)
        tracker._cheap_sync = cheap_sync
        for t, (rows, rewards, dones, dropped, success) in enumerate(steps):
            tracker.step(torch.tensor(rewards), torch.tensor(dones), dropped=dropped, rows=rows,
                         success=None if success is None else torch.tensor(success))
            if t == 100:  # a read in the middle: the rest is kept and read later
                assert tracker.games == len(_reference(steps[:101], num_envs, mode)[0])
        want_r, want_l, want_s = _reference(steps, num_envs, mode)
        assert tracker.games == len(want_r) > 50
        assert list(tracker.finished_returns) == pytest.approx(want_r, abs=1e-5)  # float32 rewards
        assert list(tracker.finished_lengths) == want_l
        assert list(tracker.finished_successes) == want_s and len(want_s) > 10


def test_ended_episodes_wait_on_the_device_until_read_or_too_many():
    on_cpu = EpisodeTracker(2, 10, torch.device("cpu"))
    on_cpu.step(torch.ones(2), torch.tensor([False, False]))
    assert on_cpu._cheap_sync and not on_cpu._pending  # on a CPU a step where nothing ended keeps nothing
    tracker = EpisodeTracker(2, 10, torch.device("cpu"))
    tracker._cheap_sync = False  # the GPU's path
    for _ in range(3):
        tracker.step(torch.ones(2), torch.tensor([True, False]))
    assert len(tracker._pending) == 3  # nothing read yet
    assert tracker.mean_return() == 1.0 and tracker.games == 3 and not tracker._pending
    for _ in range(EpisodeTracker.MAX_PENDING):
        tracker.step(torch.ones(2), torch.tensor([False, False]))
    assert len(tracker._pending) == 0  # read anyway after MAX_PENDING steps
    assert tracker.games == 3
