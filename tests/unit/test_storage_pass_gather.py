"""RolloutStorage.minibatches gathers a small rollout once per pass and slices it: the same minibatches, row for
row, as gathering each minibatch on its own (what a rollout above PASS_GATHER_BYTES does)."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.algos.core import storage as storage_module
from rlchain.algos.core.storage import RolloutStorage, obs_buffer_layout
from rlchain.envs.obs_dict import ObsDict

FIELDS = ("obs", "actions", "log_probs", "values", "returns", "advantages", "params", "index")


def _filled(space, horizon=8, envs=5):
    storage = RolloutStorage(horizon, envs, *obs_buffer_layout(space), (2,), torch.float32, 4, 1, torch.device("cpu"))
    gen = torch.Generator().manual_seed(0)
    for t in range(horizon):
        sample = space.sample()
        obs = ObsDict({k: torch.as_tensor(np.stack([v] * envs)) for k, v in sample.items()}) \
            if isinstance(sample, dict) else torch.randn(envs, *space.shape, generator=gen)
        storage.add(t, obs, torch.randn(envs, 2, generator=gen), torch.randn(envs, generator=gen),
                    torch.randn(envs, 1, generator=gen), torch.randn(envs, 4, generator=gen))
        storage.add_outcome(t, torch.randn(envs, 1, generator=gen), torch.zeros(envs, dtype=torch.bool),
                            torch.zeros(envs, dtype=torch.bool))
    return storage


def _batches(storage, limit, shuffle, monkeypatch):
    monkeypatch.setattr(storage_module, "PASS_GATHER_BYTES", limit)
    torch.manual_seed(3)  # the same permutation on both sides
    return list(storage.minibatches(10, torch.arange(40.0), shuffle=shuffle))


def _equal(a, b):
    if isinstance(a, ObsDict):
        return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    return torch.equal(a, b)


@pytest.mark.parametrize("shuffle", [True, False])
@pytest.mark.parametrize("space", [gym.spaces.Box(-1, 1, (3,), np.float32),
                                   gym.spaces.Dict({"a": gym.spaces.Box(0, 255, (2, 2), np.uint8),
                                                    "b": gym.spaces.Box(-1, 1, (3,), np.float32)})])
def test_pass_gather_gives_the_minibatches_of_one_gather_each(space, shuffle, monkeypatch):
    storage = _filled(space)
    whole = _batches(storage, 1 << 30, shuffle, monkeypatch)
    each = _batches(storage, 0, shuffle, monkeypatch)
    assert len(whole) == len(each) == 4
    for a, b in zip(whole, each):
        for field in FIELDS:
            assert _equal(getattr(a, field), getattr(b, field)), field
    # each row is the rollout's row at its index (the advantages were 0..39 in time-major order)
    assert torch.equal(torch.cat([b.advantages for b in whole]), torch.cat([b.index for b in whole]).float())
