"""config.torch_compile: parsing rl_games' forms and compiling without changing parameter names."""

import pytest
import torch

from rlchain.config.compile import CompileSpec, parse_compile
from rlchain.models.compile import compile_network


@pytest.mark.parametrize("value,expect", [
    (False, None), (None, None), ("False", None), (True, CompileSpec()),
    ("reduce-overhead", CompileSpec("reduce-overhead", "reduce-overhead")),
    ({"mode": "max-autotune"}, CompileSpec("max-autotune", "max-autotune")),
    ({"mode": "default", "critic_mode": "reduce-overhead", "backend": "eager"},
     CompileSpec("default", "reduce-overhead", "eager")),
])
def test_parse_compile(value, expect):
    assert parse_compile(value) == expect


def test_compiled_network_keeps_state_dict_and_outputs():
    torch.manual_seed(0)
    net = torch.nn.Sequential(torch.nn.Linear(3, 8), torch.nn.Tanh(), torch.nn.Linear(8, 2))
    x = torch.randn(4, 3)
    before = net(x)
    keys = list(net.state_dict())
    compile_network(net, "default", "eager")  # the eager backend runs dynamo without a C++ compiler
    assert list(net.state_dict()) == keys
    assert torch.allclose(net(x), before)
