"""The one optimizer step (rlchain.algos.core.optimizer_step) and the agent contract AdamAgent keeps."""

import copy

import pytest
import torch

from rlchain.algos.core.adam_agent import AdamAgent, Agent, loss_stats
from rlchain.algos.core.optimizer_step import optimizer_step
from rlchain.errors import DivergenceError


def _model_and_loss(seed: int = 0):
    torch.manual_seed(seed)
    model = torch.nn.Sequential(torch.nn.Linear(3, 4), torch.nn.Tanh(), torch.nn.Linear(4, 1))
    x = torch.randn(8, 3)
    return model, x


def test_a_step_is_the_hand_written_zero_grad_backward_clip_step():
    model, x = _model_and_loss()
    twin = copy.deepcopy(model)
    opt, twin_opt = torch.optim.Adam(model.parameters(), lr=0.1), torch.optim.Adam(twin.parameters(), lr=0.1)
    for _ in range(3):
        stats = optimizer_step(opt, model(x).square().mean(), max_norm=0.05,
                               stats=lambda norm: {"grad_norm": float(norm)})
        twin_opt.zero_grad(set_to_none=True)
        twin(x).square().mean().backward()
        norm = torch.nn.utils.clip_grad_norm_(list(twin.parameters()), 0.05)
        twin_opt.step()
        assert stats["grad_norm"] == float(norm) and float(norm) > 0.05  # the norm before clipping
    for a, b in zip(model.parameters(), twin.parameters()):
        assert torch.equal(a, b)


def test_a_non_finite_statistic_raises_before_the_step_and_drops_the_gradients():
    model, x = _model_and_loss()
    before = [p.detach().clone() for p in model.parameters()]
    opt = torch.optim.Adam(model.parameters(), lr=0.1)
    loss = model(x).mean() * float("nan")
    with pytest.raises(DivergenceError, match="loss = nan in the test update"):
        optimizer_step(opt, loss, stats=lambda norm: {"loss": float(loss)}, what="the test update")
    assert all(torch.equal(p, b) for p, b in zip(model.parameters(), before))
    assert all(p.grad is None for p in model.parameters())
    assert not opt.state  # Adam never stepped


def test_adam_agent_keeps_the_agent_contract_and_its_linear_schedule():
    model, x = _model_and_loss()
    agent = AdamAgent(model, lr=1e-2, lr_schedule="linear", min_lr=1e-3)
    assert isinstance(agent, Agent)
    loss = model(x).square().mean()
    stats = agent.step(loss, float("inf"), lambda norm: loss_stats(loss, norm))
    assert set(stats) == {"loss", "grad_norm"} and stats["grad_norm"] > 0
    agent.apply_progress(0.5)
    assert agent.lr == pytest.approx(5.5e-3)
    agent.scale_lr(0.5)
    assert agent.lr == pytest.approx(2.75e-3)
    constant = AdamAgent(model, lr=1e-2)
    constant.apply_progress(0.5)
    assert constant.lr == 1e-2
