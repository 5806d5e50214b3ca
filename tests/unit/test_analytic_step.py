"""PPO's minibatch step with its gradients written out (rlchain/algos/ppo/analytic_step.py): on random batches the
same loss and statistics as autograd's path (bit for bit for a Gaussian) and the same gradients up to float
rounding, for the losses a config names (RLlib's KL penalty and clamped value loss, rl_games' clipped value loss,
entropy, per-minibatch advantages) on Gaussian and categorical policies, odd row counts (RLlib's minibatches
without their masked rows) included; everything outside the plain case keeps autograd's path."""

import copy

import gymnasium as gym
import pytest
import torch

import rlchain.algos.ppo.loss as ppo_loss_module
from rlchain.algos.core.losses import policy_loss, vtrace_policy_loss
from rlchain.algos.core.storage import Batch
from rlchain.config.load import parse_params
from rlchain.config.network import ContinuousSpaceConfig, DiscreteSpaceConfig, MlpConfig, NetworkConfig, SpaceConfig
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import Categorical, DiagGaussian
from rlchain.networks.actor_critic import ActorCriticBuilder
from tests.conftest import BASE

OBS = 5


def _model(space: gym.Space, sigma_is_logstd: bool = True, fixed_sigma: bool = False, **network) -> ActorCritic:
    builder = ActorCriticBuilder()
    builder.load(NetworkConfig(space=SpaceConfig(continuous=ContinuousSpaceConfig(fixed_sigma=fixed_sigma),
                                                 discrete=DiscreteSpaceConfig()), **network))
    continuous = isinstance(space, gym.spaces.Box)
    torch.manual_seed(0)
    net = builder.build("n", action_space=space, input_shape=(OBS,),
                        actions_num=space.shape[0] if continuous else int(space.n), value_size=1)
    dist = DiagGaussian(space, sigma_is_logstd, True) if continuous else Categorical(int(space.n))
    return ActorCritic(net, dist, (OBS,), 1, True, False)


def _cfg(**config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update(config)
    return parse_params(raw, "cfg.yaml").config


def _batch(model: ActorCritic, rows: int, seed: int) -> tuple[Batch, torch.Tensor]:
    """A random minibatch whose stored policy is near the model's, and a reference policy for the KL."""
    gen = torch.Generator().manual_seed(seed)
    obs = torch.randn(rows, OBS, generator=gen)
    with torch.no_grad():
        params, values, _ = model.evaluate(obs)
    dist = model.dist
    if isinstance(dist, DiagGaussian):
        actions = params[:, :dist.dim] + params[:, dist.dim:] * torch.randn(rows, dist.dim, generator=gen)
        reference = params * (1.0 + 0.2 * torch.rand(params.shape, generator=gen))
    else:
        actions = torch.randint(0, dist.param_size, (rows,), generator=gen)
        reference = params + 0.3 * torch.randn(params.shape, generator=gen)
    # stored log-probs off by up to +-0.5: some ratios inside the clip range, some outside on both sides
    log_probs = dist.log_prob(params, actions) + torch.rand(rows, generator=gen) - 0.5
    stored = values + 0.5 * torch.randn(values.shape, generator=gen)
    returns = values + 2.0 * torch.randn(values.shape, generator=gen)
    advantages = torch.randn(rows, generator=gen)
    return Batch(obs=obs, actions=actions, log_probs=log_probs, values=stored, returns=returns,
                 advantages=advantages, params=reference), reference


def _step(model, cfg, batch, reference, analytic, monkeypatch, kl_coef=None, entropy_coef=0.01,
          surrogate=policy_loss):
    if not analytic:
        monkeypatch.setattr(ppo_loss_module, "analytic_step", lambda *args, **kwargs: None)
    model.zero_grad(set_to_none=True)
    loss, stats, aux, current = ppo_loss_module.ppo_loss(
        model, cfg, batch, torch.tensor(entropy_coef), reference, surrogate,
        kl_coef=None if kl_coef is None else torch.tensor(kl_coef))
    kind = type(loss.grad_fn).__name__
    loss.backward()
    monkeypatch.undo()
    return loss.detach(), stats, current, [p.grad.clone() for p in model.parameters()], kind


CASES = [  # (space, model and network keys, config keys, KL penalty coefficient)
    (gym.spaces.Box(-2, 2, (1,)), {"mlp": MlpConfig(units=[32, 32], activation="relu")},
     {"value_loss_clip": 10.0, "critic_coef": 2.0, "e_clip": 0.3}, 0.45),  # RLlib's tuned Pendulum
    (gym.spaces.Box(-1, 1, (3,)), {"mlp": MlpConfig(units=[16, 8], activation="elu"), "separate": True,
                                   "fixed_sigma": True},
     {"clip_value": True, "value_loss_clip": None, "normalize_advantage": True,
      "advantage_normalization": "minibatch", "bounds_loss_coef": 0.5}, None),  # rlchain's ppo_pendulum's kind
    (gym.spaces.Box(-1, 1, (2,)), {"mlp": MlpConfig(units=[8], activation="tanh"), "sigma_is_logstd": False},
     {"clip_value": False, "value_loss_clip": 0.5, "bounds_loss_coef": 0.3, "bound_loss_type": "regularisation"},
     0.2),
    (gym.spaces.Discrete(3), {"mlp": MlpConfig(units=[16, 16], activation="tanh")},
     {"clip_value": True, "value_loss_clip": None}, 0.3),
    (gym.spaces.Discrete(2), {"mlp": MlpConfig(units=[8], activation="None"), "separate": True},
     {"clip_value": False, "value_loss_clip": None}, None),
]


@pytest.mark.parametrize("space,network,config,kl_coef", CASES)
@pytest.mark.parametrize("rows", [128, 117, 1])
def test_the_written_out_step_is_autograds_up_to_rounding(space, network, config, kl_coef, rows, monkeypatch):
    model = _model(space, **network)
    if isinstance(space, gym.spaces.Box):  # means about the bounds loss's edge 1.1: rows on both sides of it
        with torch.no_grad():
            model.a2c_network.mu.bias.fill_(1.1)
    cfg = _cfg(**config)
    for seed in range(3):
        batch, reference = _batch(model, rows, seed)
        want = _step(model, cfg, batch, reference, False, monkeypatch, kl_coef)
        got = _step(model, cfg, batch, reference, True, monkeypatch, kl_coef)
        assert got[4] == "_WrittenOutBackwardBackward" and want[4] != got[4]
        for a, b in zip(got[:3], want[:3]):  # the loss, the statistics, the policy's params
            torch.testing.assert_close(a, b, rtol=1e-6, atol=1e-7)
        if isinstance(space, gym.spaces.Box):  # the same ops on the same floats (a categorical's log-softmax on a
            assert all(torch.equal(a, b) for a, b in zip(got[:3], want[:3]))  # tensor without grad: rounding)
        for (name, _), a, b in zip(model.named_parameters(), got[3], want[3]):
            assert a.shape == b.shape, name
            assert (a - b).abs().max() <= 1e-6 * max(b.abs().max().item(), 1.0), name


def test_the_statistics_cover_clipped_and_unclipped_rows():
    model = _model(gym.spaces.Box(-2, 2, (1,)), mlp=MlpConfig(units=[32, 32], activation="relu"))
    batch, _ = _batch(model, 128, 0)
    with torch.no_grad():
        params, _, _ = model.evaluate(batch.obs)
    ratio = torch.exp(model.dist.log_prob(params, batch.actions) - batch.log_probs)
    assert (ratio > 1.3).any() and (ratio < 0.7).any() and ((ratio - 1).abs() < 0.3).any()


@pytest.mark.parametrize("change", ["smooth_clamp", "impala", "no_grad", "hook", "softplus"])
def test_outside_the_plain_case_autograd_takes_the_step(change, monkeypatch):
    space = gym.spaces.Box(-1, 1, (2,))
    model = _model(space, mlp=MlpConfig(units=[8], activation="relu"))
    config, surrogate = {}, policy_loss
    if change == "smooth_clamp":
        config = {"use_smooth_clamp": True}
    elif change == "impala":
        surrogate = vtrace_policy_loss
    elif change == "hook":
        model.a2c_network.mu.register_forward_hook(lambda module, args, out: out * 2)
    elif change == "softplus":
        model.dist.parametrization = "softplus"
    batch, reference = _batch(model, 16, 0)
    cfg = _cfg(**config)
    with torch.set_grad_enabled(change != "no_grad"):
        loss, *_ = ppo_loss_module.ppo_loss(model, cfg, batch, torch.tensor(0.0), reference, surrogate)
    assert loss.grad_fn is None or type(loss.grad_fn).__name__ != "_WrittenOutBackwardBackward"
