"""RunningMeanStd.update: batches folded in one at a time give the moments of all of them together."""

import pytest
import torch

from rlchain.models.normalization import RunningMeanStd


def test_batches_folded_in_give_the_moments_of_their_concatenation():
    torch.manual_seed(0)
    batches = [torch.randn(n, 3, dtype=torch.float64) * 2 + 5 for n in (7, 20, 3)]
    rms = RunningMeanStd((3,), epsilon=1e-12)
    for batch in batches:
        rms.update(batch)
    every = torch.cat(batches)
    torch.testing.assert_close(rms.running_mean, every.mean(0))
    torch.testing.assert_close(rms.running_var, every.var(0, unbiased=False))
    assert float(rms.count) == pytest.approx(len(every))
