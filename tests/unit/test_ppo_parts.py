"""The PPO agent's parts: the minibatch loss against its terms summed by hand, the optimizer and schedules
(adaptive lr, portable checkpoint state), and which way the step runner runs."""

import copy
import dataclasses

import gymnasium as gym
import pytest
import torch
import torch.nn as nn

from rlchain.algos.core.losses import policy_loss, value_loss
from rlchain.algos.core.storage import Batch
from rlchain.algos.ppo.agent import PPOAgent
from rlchain.algos.ppo.loss import STEP_STATS, named_stats, ppo_loss, stats_vector
from rlchain.algos.ppo.optimizer import ScheduledAdam
from rlchain.config.load import parse_params
from rlchain.models.actor_critic import ActorCritic
from rlchain.models.distributions import make_distribution
from tests.conftest import BASE


class Net(nn.Module):
    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.mu = nn.Linear(3, 2)
        self.logstd = nn.Parameter(torch.full((2,), -0.5))
        self.value = nn.Linear(3, 1)

    def forward(self, input_dict):
        obs = input_dict["obs"]
        return self.mu(obs), self.logstd.expand(obs.shape[0], 2), self.value(obs), None


def _cfg(**config):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update({"num_actors": 4, "horizon_length": 4, "minibatch_size": 8, "e_clip": 0.2,
                                    "critic_coef": 2.0, "clip_value": True, "learning_rate": 1e-3, **config})
    return parse_params(raw, "cfg.yaml").config


def _model():
    return ActorCritic(Net(), make_distribution("continuous_a2c_logstd", gym.spaces.Box(-1.0, 1.0, (2,)), False),
                       (3,), 1, False, False)


def _batch(model):
    gen = torch.Generator().manual_seed(3)
    obs, actions = torch.randn(8, 3, generator=gen), torch.randn(8, 2, generator=gen)
    with torch.no_grad():
        params, values, _ = model.evaluate(obs, (), None, 1, None)
    params = params + 0.1 * torch.randn(params.shape, generator=gen)  # the rollout's policy, a little off
    return Batch(obs=obs, actions=actions, log_probs=model.dist.log_prob(params, actions), values=values + 0.3,
                 returns=torch.randn(8, 1, generator=gen), advantages=torch.randn(8, generator=gen), params=params)


@pytest.mark.parametrize("train_critic", [True, False])
def test_the_loss_is_its_terms_summed_by_hand(train_critic):
    cfg, model = _cfg(bounds_loss_coef=0.01), _model()
    batch, coef = _batch(model), torch.tensor(0.05)
    surrogate = policy_loss
    loss, stats, aux, current = ppo_loss(model, cfg, batch, coef, batch.params, surrogate, train_critic)
    params, values, _ = model.evaluate(batch.obs, (), None, 1, None)
    log_probs, entropy = model.dist.log_prob_and_entropy(params, batch.actions)
    a_loss = policy_loss(batch.log_probs, log_probs, batch.advantages, 0.2).mean()
    c_loss = value_loss(values, batch.values, batch.returns, 0.2, True).mean() if train_critic else torch.tensor(0.0)
    b_loss = model.dist.bounds_loss(params, cfg.bound_loss_type).mean()
    expected = a_loss + 0.5 * 2.0 * c_loss - 0.05 * entropy.mean() + 0.01 * b_loss
    torch.testing.assert_close(loss, expected)
    torch.testing.assert_close(stats[:4], torch.stack([a_loss, c_loss, entropy.mean(), b_loss]).detach())
    assert aux == {} and torch.equal(current, params.detach())
    assert float(stats[5]) == pytest.approx(float(model.dist.kl(batch.params, params.detach()).mean()), rel=1e-5)
    loss.backward()  # a loss to train on; the value head only when it trains the critic
    network = model.a2c_network
    assert network.mu.weight.grad is not None and (network.value.weight.grad is not None) == train_critic


def test_minibatch_advantage_normalization_normalizes_in_the_loss():
    model = _model()
    batch = _batch(model)
    surrogate = policy_loss
    coef = torch.tensor(0.0)
    per_minibatch = ppo_loss(model, _cfg(advantage_normalization="minibatch"), batch, coef, batch.params, surrogate,
                             False)[0]
    adv = batch.advantages
    normalized = dataclasses.replace(batch, advantages=(adv - adv.mean()) / (adv.std() + 1e-8))
    by_hand = ppo_loss(model, _cfg(), normalized, coef, batch.params, surrogate, False)[0]
    torch.testing.assert_close(per_minibatch, by_hand)  # the batch mode leaves the loss's advantages as given


def test_the_statistics_vector_reads_back_by_name():
    vector = stats_vector(torch.tensor(9.0), torch.arange(6.0), {"aux": torch.tensor(7.0)}, torch.tensor(8.0))
    named = named_stats(vector.tolist(), ["aux"])
    assert list(named) == [*STEP_STATS, "losses/aux"] and named["loss"] == 9.0 and named["grad_norm"] == 8.0


def test_the_adaptive_lr_follows_the_kl_and_reaches_the_optimizer():
    params = list(_model().parameters())
    adam = ScheduledAdam(params, _cfg(lr_schedule="adaptive", kl_threshold=0.01), torch.device("cpu"))
    adam.follow_kl(0.5)  # far above 2 x threshold: lr / 1.5
    assert adam.lr == pytest.approx(1e-3 / 1.5) and adam.optimizer.param_groups[0]["lr"] == adam.lr
    adam.follow_kl(0.001)  # below threshold / 2: lr x 1.5
    assert adam.lr == pytest.approx(1e-3)
    assert adam.set_hyperparam("kl_threshold", 0.1) is False and adam.schedule.kl_threshold == 0.1


def test_a_capturable_optimizers_state_loads_into_an_eager_one_and_back():
    cfg = _cfg(lr_schedule="linear", schedule_entropy=True, entropy_coef=0.01)
    graphed = ScheduledAdam(list(_model().parameters()), cfg, torch.device("cpu"), capturable=True)
    eager = ScheduledAdam(list(_model().parameters()), cfg, torch.device("cpu"))
    graphed.apply_progress(0.5)
    half = cfg.min_lr + (1e-3 - cfg.min_lr) / 2  # linear: halfway from learning_rate to min_lr
    assert graphed.lr == pytest.approx(half) and float(graphed.lr_live) == pytest.approx(half)
    assert graphed.entropy_coef == pytest.approx((0.01 + 1e-4) / 2)
    state = graphed.state_dict()
    assert state["optimizer"]["param_groups"][0]["capturable"] is False
    eager.load_state_dict(copy.deepcopy(state))
    assert eager.lr == pytest.approx(half) and eager.optimizer.param_groups[0]["lr"] == pytest.approx(half)
    graphed.load_state_dict(eager.state_dict())
    assert graphed.optimizer.param_groups[0]["lr"] is graphed.lr_step


def test_the_minibatch_step_says_which_way_it_runs():  # compiled: tests/smoke/test_compile_update.py
    cfg = _cfg()
    assert PPOAgent(_model(), cfg, torch.device("cpu")).mode == "eager"
    assert PPOAgent(_model(), cfg, torch.device("cpu"), cuda_graph=True).mode == "graphed"
