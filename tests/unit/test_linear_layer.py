"""rlchain.networks.layers.Linear: nn.Linear's parameters and values, a faster weight gradient for narrow inputs."""

import torch
import torch.nn as nn

from rlchain.config.network import InitializerConfig
from rlchain.networks.layers import NARROW_INPUTS, Linear, linear


def _pair(in_features: int) -> tuple[Linear, nn.Linear]:
    torch.manual_seed(0)
    ours = linear(in_features, 16, InitializerConfig())
    plain = nn.Linear(in_features, 16)
    plain.load_state_dict(ours.state_dict())
    return ours, plain


def test_a_narrow_layer_gives_nn_linear_values_and_gradients():
    assert isinstance(linear(3, 16, InitializerConfig()), Linear)
    for in_features in (1, 3, NARROW_INPUTS, NARROW_INPUTS + 1):
        ours, plain = _pair(in_features)
        assert list(ours.state_dict()) == list(plain.state_dict())
        x = torch.randn(257, in_features)
        grad = torch.randn(257, 16)
        out, ref = ours(x), plain(x)
        assert torch.equal(out, ref)  # same forward values, bit for bit
        out.backward(grad)
        ref.backward(grad)
        assert ours.weight.grad.shape == plain.weight.grad.shape and ours.weight.grad.is_contiguous()
        torch.testing.assert_close(ours.weight.grad, plain.weight.grad, rtol=1e-5, atol=1e-5)  # summed in another order
        torch.testing.assert_close(ours.bias.grad, plain.bias.grad, rtol=1e-5, atol=1e-5)


def test_input_gradients_flow_and_inference_runs_plain_linear():
    ours, plain = _pair(4)
    x = torch.randn(8, 4, requires_grad=True)
    ours(x).sum().backward()
    expected = plain.weight.sum(0).expand(8, 4)
    torch.testing.assert_close(x.grad, expected)
    with torch.no_grad():
        assert torch.equal(ours(x), plain(x))
    assert torch.equal(ours(x[None]), plain(x[None]))  # (1, B, in): F.linear's batched form
