"""RunningMeanStd.normalize reuses its (shift, factor) pair on a CPU while the statistics stay as they are, and
computes it again after anything writes them (an update, a checkpoint load): always the formula's values."""

import torch

from rlchain.models.normalization import RunningMeanStd


def _formula(norm, x, scale=1.0):
    inv = torch.rsqrt(norm.running_var + norm.epsilon)
    y = torch.addcmul((-norm.running_mean * inv).to(x.dtype), x, (inv * scale).to(x.dtype))
    return y.clamp(-norm.clip, norm.clip)


def _norm():
    torch.manual_seed(0)
    norm = RunningMeanStd((3,))
    norm.update(torch.randn(64, 3) * 4 + 2)
    return norm


def test_the_pair_is_reused_while_the_statistics_stay():
    norm, x = _norm(), torch.randn(8, 3)
    first = norm._affine(x, 1.0)
    assert all(a is b for a, b in zip(first, norm._affine(x, 1.0)))
    assert torch.equal(norm.normalize(x), _formula(norm, x))
    assert norm._affine(x, 0.5)[1] is not first[1]  # another scale is another pair
    assert torch.equal(norm.normalize(x, 0.5), _formula(norm, x, 0.5))


def test_an_update_or_a_load_gives_the_new_statistics():
    norm, x = _norm(), torch.randn(8, 3)
    before = norm.normalize(x)
    norm.update(torch.randn(64, 3) * 10 - 5)
    after = norm.normalize(x)
    assert not torch.equal(before, after) and torch.equal(after, _formula(norm, x))
    other = RunningMeanStd((3,))
    norm.load_state_dict(other.state_dict())
    assert torch.equal(norm.normalize(x), _formula(other, x))


def test_inference_mode_and_tracing_get_the_same_values():
    norm, x = _norm(), torch.randn(8, 3)
    with torch.inference_mode():
        inside = norm.normalize(x)
    assert torch.equal(norm.normalize(x), inside)

    class Normalize(torch.nn.Module):
        def __init__(self):
            super().__init__()
            self.norm = norm

        def forward(self, t):
            return self.norm.normalize(t)

    traced = torch.jit.trace(Normalize(), x)
    norm.update(torch.randn(64, 3) + 7)
    assert torch.equal(traced(x), _formula(norm, x))  # the trace reads the live buffers, not a cached pair
