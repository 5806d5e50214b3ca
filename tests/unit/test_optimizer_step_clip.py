"""optimizer_step's clip: with max_norm inf only the gradients' norm is measured (torch's clip would multiply them
by 1.0); the same norm and gradients as torch.nn.utils.clip_grad_norm_, and a finite max_norm still clips."""

import math

import pytest
import torch

from rlchain.algos.core.optimizer_step import clip_grad_norm


def _params(scale):
    torch.manual_seed(0)
    params = [torch.nn.Parameter(torch.randn(5, 3)), torch.nn.Parameter(torch.randn(7))]
    for p in params:
        p.grad = torch.randn_like(p) * scale
    return params


@pytest.mark.parametrize("max_norm", [math.inf, 0.5, 100.0])
def test_clip_grad_norm_matches_torch(max_norm):
    ours, theirs = _params(3.0), _params(3.0)
    norm = clip_grad_norm(ours, max_norm)
    expected = torch.nn.utils.clip_grad_norm_(theirs, max_norm)
    assert torch.equal(norm, expected)
    for a, b in zip(ours, theirs):
        assert torch.equal(a.grad, b.grad)
    clipped = torch.linalg.vector_norm(torch.cat([p.grad.flatten() for p in ours]))
    assert clipped <= max_norm * 1.0001 if max_norm < norm else torch.isclose(clipped, norm)


def test_clip_grad_norm_inf_does_not_write_the_gradients():
    params = _params(1.0)
    versions = [p.grad._version for p in params]  # an in-place multiply (torch's clip by 1.0) would bump them
    clip_grad_norm(params, math.inf)
    assert [p.grad._version for p in params] == versions
    clip_grad_norm(params, 0.1)
    assert all(p.grad._version > v for p, v in zip(params, versions))
