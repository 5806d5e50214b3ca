"""The per-step numpy -> device conversion (pinned staging on CUDA)."""

import numpy as np
import pytest
import torch

from rlchain.algos.base.context import to_device


def test_cpu_shares_numpy_memory():
    x = np.arange(6, dtype=np.float32).reshape(2, 3)
    t = to_device(x, torch.device("cpu"))
    x[0, 0] = 42.0
    assert t[0, 0].item() == 42.0 and t.dtype == torch.float32


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
@pytest.mark.parametrize("array", [np.arange(12, dtype=np.float32).reshape(3, 4)[:, ::2],  # strided
                                   np.ones((4, 2), dtype=bool), np.arange(5, dtype=np.uint8)])
def test_cuda_copy_is_exact(array):
    frozen = array.copy()
    frozen.setflags(write=False)  # envpool hands out read-only arrays
    for x in (array, frozen):
        t = to_device(x, torch.device("cuda"))
        torch.cuda.synchronize()
        assert t.is_cuda and np.array_equal(t.cpu().numpy(), x)
