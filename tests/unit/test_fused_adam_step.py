"""fused_adam_step: torch's fused Adam kernel called directly gives optimizer.step()'s parameters and state, bit for
bit; where the plain case does not hold it does nothing and says so."""

import copy

import pytest
import torch

from rlchain.algos.core.fused_adam_step import fused_adam_step


def _net():
    torch.manual_seed(0)
    return torch.nn.Sequential(torch.nn.Linear(3, 16), torch.nn.ReLU(), torch.nn.Linear(16, 2))


def _grads(net, step):
    gen = torch.Generator().manual_seed(step)
    for p in net.parameters():
        p.grad = torch.randn(p.shape, generator=gen)


@pytest.mark.parametrize("weight_decay", [0.0, 0.01])
def test_same_parameters_and_state_as_torch(weight_decay):
    ours, theirs = _net(), _net()
    opt_ours = torch.optim.Adam(ours.parameters(), lr=2e-3, weight_decay=weight_decay, fused=True)
    opt_theirs = torch.optim.Adam(theirs.parameters(), lr=2e-3, weight_decay=weight_decay, fused=True)
    taken = []
    for step in range(5):
        _grads(ours, step)
        _grads(theirs, step)
        taken.append(fused_adam_step(opt_ours))
        if not taken[-1]:
            opt_ours.step()
        opt_theirs.step()
    assert taken == [False, True, True, True, True]  # torch's first step creates the state
    for a, b in zip(ours.parameters(), theirs.parameters()):
        assert torch.equal(a, b)
    sa, sb = opt_ours.state_dict()["state"], opt_theirs.state_dict()["state"]
    assert all(torch.equal(sa[i][k], sb[i][k]) for i in sa for k in sa[i])


def _stepped(**kwargs):
    net = _net()
    opt = torch.optim.Adam(net.parameters(), lr=1e-3, **kwargs)
    _grads(net, 0)
    opt.step()
    _grads(net, 1)
    return net, opt


@pytest.mark.parametrize("kwargs", [{}, {"fused": True, "amsgrad": True}, {"fused": True, "maximize": True}])
def test_other_settings_are_left_to_torch(kwargs):
    net, opt = _stepped(**kwargs)
    before = [p.clone() for p in net.parameters()]
    assert not fused_adam_step(opt)
    assert all(torch.equal(a, b) for a, b in zip(before, net.parameters()))


def test_hooks_and_missing_gradients_are_left_to_torch():
    net, opt = _stepped(fused=True)
    handle = opt.register_step_pre_hook(lambda *a: None)
    assert not fused_adam_step(opt)
    handle.remove()
    assert fused_adam_step(opt)
    _grads(net, 2)
    next(net.parameters()).grad = None
    assert not fused_adam_step(opt)
    other = copy.deepcopy(opt)
    other.add_param_group({"params": [torch.nn.Parameter(torch.zeros(2))]})
    assert not fused_adam_step(other)
