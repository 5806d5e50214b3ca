"""EpisodeTracker.host_step (numpy, CPU) keeps exactly the statistics EpisodeTracker.step keeps."""

import numpy as np
import pytest
import torch

from rlchain.algos.base.episodes import EpisodeTracker


def _pair(n: int = 4) -> tuple[EpisodeTracker, EpisodeTracker]:
    return EpisodeTracker(n, 5, torch.device("cpu")), EpisodeTracker(n, 5, torch.device("cpu"))


def _same(a: EpisodeTracker, b: EpisodeTracker) -> None:
    assert torch.equal(a.returns, b.returns) and torch.equal(a.lengths, b.lengths)
    assert list(a.finished_returns) == list(b.finished_returns)
    assert list(a.finished_lengths) == list(b.finished_lengths)
    assert a.games == b.games


@pytest.mark.parametrize("rows", [slice(None), slice(0, 2), slice(2, 4)])
def test_host_step_matches_step(rows):
    rng = np.random.default_rng(0)
    torch_side, host_side = _pair()
    n = len(range(4)[rows])
    for i in range(200):
        rewards = rng.normal(size=n).astype(np.float32)
        dones = rng.random(n) < 0.1
        dropped = (rng.random(n) < 0.05) if i % 3 == 0 else None
        torch_side.step(torch.from_numpy(rewards.copy()), torch.from_numpy(dones.copy()), dropped=dropped, rows=rows)
        host_side.host_step(rewards, dones, dropped=dropped, rows=rows)
    assert torch_side.games > 5  # episodes ended and were recorded, on both sides alike
    _same(torch_side, host_side)


def test_host_step_leaves_its_inputs_and_follows_a_replaced_tensor():
    tracker = EpisodeTracker(2, 5, torch.device("cpu"))
    rewards, dones = np.ones(2, np.float32), np.array([True, False])
    tracker.host_step(rewards, dones)
    assert dones.tolist() == [True, False] and rewards.tolist() == [1.0, 1.0]
    tracker.returns = torch.full((2,), 10.0, dtype=torch.float64)  # a restore may hand new tensors
    tracker.host_step(rewards, np.zeros(2, bool))
    assert tracker.returns.tolist() == [11.0, 11.0]
    assert list(tracker.finished_returns) == [1.0]


def test_host_step_with_success_takes_the_tensor_path():
    torch_side, host_side = _pair(2)
    success = np.array([1.0, np.nan])
    for dones in ([False, False], [True, True]):
        d = np.array(dones)
        torch_side.step(torch.ones(2), torch.from_numpy(d.copy()), success=success)
        host_side.host_step(np.ones(2, np.float32), d, success=success)
    _same(torch_side, host_side)
    assert list(torch_side.finished_successes) == list(host_side.finished_successes) == [1.0]
