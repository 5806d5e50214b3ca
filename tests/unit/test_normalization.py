"""rlchain.models.normalization: chunked batch moments and the fused (uint8-scaling) normalize."""

import numpy as np
import torch

from rlchain.models.base import as_float
from rlchain.models.normalization import RunningMeanStd, batch_moments, merge_moments


def test_batch_moments_in_chunks_equal_float64_moments():
    x = torch.as_tensor(np.random.default_rng(0).normal(3.0, 2.0, size=(1001, 5)), dtype=torch.float32)
    mean, var, n = batch_moments(x, chunk_elements=5 * 64)  # 16 chunks, the last one short
    assert n == 1001 and mean.dtype == torch.float64
    assert torch.allclose(mean, x.double().mean(0), atol=1e-6)
    assert torch.allclose(var, x.double().var(0, unbiased=False), atol=1e-5)


def test_batch_moments_transform_is_applied_per_chunk():
    frames = torch.randint(0, 256, (300, 2, 3, 3), dtype=torch.uint8)
    calls = []

    def scaled(chunk):
        calls.append(chunk.shape[0])
        return as_float(chunk)

    mean, var, _ = batch_moments(frames, scaled, chunk_elements=18 * 100)
    assert calls == [100, 100, 100]
    ref = frames.double() / 255.0
    assert torch.allclose(mean, ref.mean(0), atol=1e-7)
    assert torch.allclose(var, ref.var(0, unbiased=False), atol=1e-7)


def test_merge_moments_of_unequal_parts():
    x = torch.randn(70, 3, dtype=torch.float64)
    parts = [x[:10], x[10:70]]
    mean, var, count = merge_moments(torch.stack([p.mean(0) for p in parts]),
                                     torch.stack([p.var(0, unbiased=False) for p in parts]),
                                     torch.tensor([10.0, 60.0], dtype=torch.float64))
    assert count.item() == 70
    assert torch.allclose(mean, x.mean(0)) and torch.allclose(var, x.var(0, unbiased=False))


def test_normalize_with_scale_equals_scaling_first():
    rms = RunningMeanStd((4,), clip=5.0)
    frames = torch.randint(0, 256, (64, 4), dtype=torch.uint8)
    rms.update(frames, as_float)
    fused = rms.normalize(frames.float(), 1.0 / 255.0)
    x = frames.float() / 255.0
    plain = ((x - rms.running_mean.float()) / torch.sqrt(rms.running_var.float() + rms.epsilon)).clamp(-5.0, 5.0)
    assert torch.allclose(fused, plain, atol=1e-5)


def test_normalize_clip_and_gradient():
    rms = RunningMeanStd((2,), clip=1.0)
    x = torch.tensor([[10.0, -10.0], [0.5, 0.0]], requires_grad=True)
    y = rms.normalize(x)
    assert y[0].tolist() == [1.0, -1.0]
    y.sum().backward()
    assert x.grad[0].tolist() == [0.0, 0.0] and x.grad[1, 0].item() > 0
