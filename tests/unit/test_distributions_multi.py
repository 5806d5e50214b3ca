"""MultiCategorical (MultiDiscrete / Tuple / MultiBinary) and action masks in rlchain.models.distributions."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch.distributions import Categorical as TorchCategorical
from torch.distributions import kl_divergence

from rlchain.models.distributions import (
    MASKED_LOGIT,
    ActionMaskError,
    Categorical,
    MultiCategorical,
    actions_num,
    make_distribution,
)

NVECS = [[3, 3], [2, 5, 3], [4]]


def _torch_dists(d: MultiCategorical, params: torch.Tensor) -> list[TorchCategorical]:
    return [TorchCategorical(logits=chunk) for chunk in params.split(d.nvec, -1)]


@pytest.mark.parametrize("nvec", NVECS)
def test_log_prob_entropy_kl_match_torch(nvec):
    torch.manual_seed(0)
    d = MultiCategorical(nvec)
    params, other = torch.randn(7, sum(nvec)), torch.randn(7, sum(nvec))
    actions = torch.stack([torch.randint(0, n, (7,)) for n in nvec], -1)
    refs, others = _torch_dists(d, params), _torch_dists(d, other)
    ref_lp = sum(r.log_prob(actions[:, k]) for k, r in enumerate(refs))
    ref_ent = sum(r.entropy() for r in refs)
    ref_kl = sum(kl_divergence(r, o) for r, o in zip(refs, others))
    assert torch.allclose(d.log_prob(params, actions), ref_lp, atol=1e-5)
    assert torch.allclose(d.entropy(params), ref_ent, atol=1e-5)
    assert torch.allclose(d.kl(params, other), ref_kl, atol=1e-5)
    lp, ent = d.log_prob_and_entropy(params, actions)
    assert torch.allclose(lp, ref_lp, atol=1e-5) and torch.allclose(ent, ref_ent, atol=1e-5)
    assert torch.allclose(d.kl(params, params), torch.zeros(7), atol=1e-6)


def test_hand_computed_uniform_logits():
    d = MultiCategorical([2, 4])
    params = torch.zeros(1, 6)
    assert d.entropy(params).item() == pytest.approx(np.log(2) + np.log(4))
    assert d.log_prob(params, torch.tensor([[1, 3]])).item() == pytest.approx(-np.log(8))


def test_mode_sample_shapes_and_ranges():
    d = MultiCategorical([2, 5, 3])
    params = torch.tensor([[0.0, 1.0, 5.0, 0, 0, 0, 0, 0, 0, 2.0]])
    assert d.mode(params).tolist() == [[1, 0, 2]]
    samples = d.sample(torch.zeros(4000, 10))
    assert samples.shape == (4000, 3) and samples.dtype == torch.long
    for k, n in enumerate(d.nvec):  # every value of every dimension, none beyond n (padding never wins)
        assert sorted(samples[:, k].unique().tolist()) == list(range(n))
    freq = (samples[:, 1] == 0).float().mean().item()
    assert freq == pytest.approx(0.2, abs=0.03)


def test_sampling_follows_the_probabilities():
    d = MultiCategorical([2, 3])
    params = torch.log(torch.tensor([[0.9, 0.1, 0.2, 0.5, 0.3]])).expand(20000, 5)
    s = d.sample(params)
    assert (s[:, 0] == 0).float().mean().item() == pytest.approx(0.9, abs=0.02)
    assert (s[:, 1] == 1).float().mean().item() == pytest.approx(0.5, abs=0.02)


def test_gradients_flow_only_to_real_logits():
    d = MultiCategorical([2, 3])
    params = torch.randn(3, 5, requires_grad=True)
    d.log_prob_and_entropy(params, torch.tensor([[0, 2], [1, 0], [1, 1]]))[0].sum().backward()
    assert params.grad is not None and torch.isfinite(params.grad).all() and params.grad.abs().sum() > 0


@pytest.mark.parametrize("dist,width", [(Categorical(5), 5), (MultiCategorical([2, 3, 4]), 9)])
def test_masked_sampling_never_picks_invalid(dist, width):
    torch.manual_seed(1)
    masks = torch.rand(3000, width) < 0.5
    if isinstance(dist, MultiCategorical):
        for seg in torch.arange(width).split(dist.nvec):
            masks[:, seg[0]] |= ~masks[:, seg].any(-1)  # at least one valid action per dimension
    else:
        masks[:, 0] |= ~masks.any(-1)
    params = dist.mask(torch.randn(3000, width) * 3, masks)
    for actions in (dist.sample(params), dist.mode(params)):
        cols = actions.reshape(3000, -1)
        offsets = torch.tensor([0, *np.cumsum(getattr(dist, "nvec", [5]))[:-1].tolist()])
        picked = masks.gather(1, cols + offsets)
        assert picked.all()
    assert torch.isfinite(dist.log_prob(params, dist.sample(params))).all()


def test_masked_entropy_kl_finite_and_match_renormalized():
    d = MultiCategorical([3, 2])
    logits = torch.tensor([[1.0, 2.0, 3.0, 0.5, -0.5]])
    mask = torch.tensor([[True, False, True, False, True]])
    params = d.mask(logits, mask)
    assert params[0, 1].item() == MASKED_LOGIT and params[0, 3].item() == MASKED_LOGIT
    # the masked dist is a categorical over {0, 2} in dim 0 and deterministic in dim 1
    ref = TorchCategorical(logits=torch.tensor([1.0, 3.0]))
    assert d.entropy(params).item() == pytest.approx(ref.entropy().item(), abs=1e-6)
    assert d.log_prob(params, torch.tensor([[2, 1]])).item() == pytest.approx(ref.log_prob(torch.tensor(1)).item())
    other = d.mask(torch.randn(1, 5), mask)
    kl = d.kl(params, other)
    assert torch.isfinite(kl).all() and kl.item() >= 0
    # gradients through masked params stay finite
    logits.requires_grad_(True)
    d.entropy(d.mask(logits, mask)).sum().backward()
    assert torch.isfinite(logits.grad).all() and logits.grad[0, 1] == 0


def test_categorical_mask_entropy_finite():
    d = Categorical(4)
    params = d.mask(torch.randn(2, 4), torch.tensor([[True, False, False, False], [True, True, False, True]]))
    ent = d.entropy(params)
    assert torch.isfinite(ent).all() and ent[0].item() == pytest.approx(0.0, abs=1e-6)
    assert d.mode(params)[0].item() == 0


def test_all_false_mask_row_raises():
    with pytest.raises(ActionMaskError, match="row 1 allows no action"):
        Categorical(3).mask(torch.zeros(2, 3), torch.tensor([[True, False, False], [False, False, False]]))
    d = MultiCategorical([2, 3])
    with pytest.raises(ActionMaskError, match="row 0, action dimension 1"):
        d.mask(torch.zeros(1, 5), torch.tensor([[True, True, False, False, False]]))


def test_mask_shape_and_box_errors():
    with pytest.raises(ActionMaskError, match=r"expected \(2, 5\)"):
        MultiCategorical([2, 3]).mask(torch.zeros(2, 5), torch.ones(2, 4, dtype=torch.bool))
    box = make_distribution("continuous_a2c_logstd", gym.spaces.Box(-1, 1, (2,)), True)
    with pytest.raises(ActionMaskError, match="use_action_masks"):
        box.mask(torch.zeros(1, 4), torch.ones(1, 2, dtype=torch.bool))


def test_make_distribution_for_multi_spaces():
    md = make_distribution("multi_discrete_a2c", gym.spaces.MultiDiscrete([3, 4]), True)
    assert isinstance(md, MultiCategorical) and md.param_size == md.mask_size == 7 and md.action_shape == (2,)
    tup = make_distribution("multi_discrete_a2c", gym.spaces.Tuple([gym.spaces.Discrete(2), gym.spaces.Discrete(3)]),
                            True)
    assert tup.nvec == [2, 3]
    mb = make_distribution("multi_discrete_a2c", gym.spaces.MultiBinary(3), True)
    assert mb.nvec == [2, 2, 2]
    with pytest.raises(ValueError, match="use multi_discrete_a2c"):
        make_distribution("discrete_a2c", gym.spaces.MultiDiscrete([3, 4]), True)
    with pytest.raises(ValueError, match="use discrete_a2c"):
        make_distribution("multi_discrete_a2c", gym.spaces.Discrete(3), True)
    assert actions_num(gym.spaces.MultiDiscrete([3, 4])) == 7
    assert actions_num(gym.spaces.Tuple([gym.spaces.Discrete(2), gym.spaces.Discrete(3)])) == 5
    assert actions_num(gym.spaces.Discrete(6)) == 6 and actions_num(gym.spaces.Box(-1, 1, (2, 3))) == 6


def test_to_env_applies_space_start():
    md = make_distribution("multi_discrete_a2c", gym.spaces.MultiDiscrete([3, 4], start=[-1, 2]), True)
    assert md.to_env(torch.tensor([[0, 3]])).tolist() == [[-1, 5]]
    cat = make_distribution("discrete_a2c", gym.spaces.Discrete(3, start=1), True)
    assert cat.to_env(torch.tensor([0, 2])).tolist() == [1, 3]
    plain = make_distribution("multi_discrete_a2c", gym.spaces.MultiDiscrete([3, 4]), True)
    a = torch.tensor([[2, 1]])
    assert plain.to_env(a) is a
