"""Discrete SAC (rlchain/algos/off_policy/sac_discrete.py): the expectations over a categorical's actions against
hand-computed values, the target entropy, one update's critic target and actor loss, and a non-Box, non-Discrete
action space refused in one line."""

import math
import os

import gymnasium as gym
import pytest
import torch

from rlchain import Runner
from rlchain.algos.off_policy.sac import soft_actor_critic_model
from rlchain.algos.off_policy.sac_agent import SACAgent
from rlchain.algos.off_policy.sac_discrete import (
    DiscreteSoftActorCritic,
    discrete_target_entropy,
    expected_terms,
    taken_q,
)
from rlchain.config import ConfigError
from rlchain.config.network import MlpConfig
from rlchain.config.off_policy import SACConfig, SACNetworkConfig
from rlchain.networks.sac_network import SACNetwork, sac_network
from tests.unit.test_sac_dqn import CONFIGS, batch


def discrete_model(n=3, **cfg):
    torch.manual_seed(0)
    net = SACNetwork(SACNetworkConfig(mlp=MlpConfig(units=[16, 16], activation="relu")), (3,), n, discrete=True)
    config = SACConfig(env_name="x", batch_size=8, **cfg)
    model = soft_actor_critic_model(net, gym.spaces.Discrete(n), (3,), 1, config, "soft_actor_critic")
    return model, config


def test_expected_terms_sum_over_the_actions_weighted_by_their_probabilities():
    logits = torch.tensor([[0.0, math.log(3.0)], [0.0, 0.0]])  # p = [0.25, 0.75] and [0.5, 0.5]
    q = torch.tensor([[1.0, 2.0], [4.0, -2.0]])
    logp_pi, q_pi = expected_terms(logits, q)
    assert q_pi.tolist() == pytest.approx([0.25 * 1 + 0.75 * 2, 0.5 * 4 - 0.5 * 2])
    assert logp_pi.tolist() == pytest.approx([0.25 * math.log(0.25) + 0.75 * math.log(0.75), math.log(0.5)])
    # an action of probability 0 adds nothing (no 0 * -inf)
    logp0, q0 = expected_terms(torch.tensor([[0.0, -1e9]]), torch.tensor([[3.0, 100.0]]))
    assert float(logp0) == pytest.approx(0.0) and float(q0) == pytest.approx(3.0)


def test_taken_q_gathers_each_critics_value_of_the_stored_action():
    q1, q2 = torch.tensor([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]), -torch.tensor([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    a, b = taken_q(q1, q2, torch.tensor([2, 0]))
    assert a.tolist() == [3.0, 4.0] and b.tolist() == [-3.0, -4.0]


def test_target_entropy_defaults_to_a_share_of_the_uniform_policys_entropy():
    assert discrete_target_entropy(2) == pytest.approx(0.98 * math.log(2))
    model, cfg = discrete_model(n=4)
    assert SACAgent(model, cfg).target_entropy == pytest.approx(0.98 * math.log(4))
    model, cfg = discrete_model(n=4, target_entropy=-1.0)  # RLlib's "auto" for a Discrete space
    assert SACAgent(model, cfg).target_entropy == -1.0


def test_update_regresses_the_taken_q_on_the_expected_soft_value_and_steps_the_actor_on_its_expectation():
    model, cfg = discrete_model(n=2, init_alpha=0.5, critic_lr=1e-3)
    agent = SACAgent(model, cfg)
    data = batch(discrete=True)
    critic, actor, target = model.network.critic, model.network.actor, model.critic_target
    with torch.no_grad():  # by hand, before the update: the soft value of the next observation, then the TD target
        p_next = torch.softmax(actor(data["next_obs"]), -1)
        soft_v = (p_next * (torch.min(*target(data["next_obs"])) - 0.5 * p_next.log())).sum(-1)
        y = data["rewards"] + data["discounts"] * (~data["terminated"]).float() * soft_v
        q1, q2 = (q.gather(-1, data["actions"].unsqueeze(-1)).squeeze(-1) for q in critic(data["obs"]))
        logits = actor(data["obs"])
    stats, td = agent.update(data)
    assert float(stats["critic_loss"]) == pytest.approx(float(((q1 - y).square() + (q2 - y).square()).mean()),
                                                        rel=1e-5)
    assert td.tolist() == pytest.approx((0.5 * ((q1 - y).abs() + (q2 - y).abs())).tolist(), rel=1e-5)
    with torch.no_grad():  # the actor's loss: the expectation under its policy before its step, on the stepped critic
        p, log_p = torch.softmax(logits, -1), torch.log_softmax(logits, -1)
        actor_loss = (p * (0.5 * log_p - torch.min(*critic(data["obs"])))).sum(-1).mean()
        logp_pi = (p * log_p).sum(-1)
    assert float(stats["actor_loss"]) == pytest.approx(float(actor_loss), rel=1e-5)
    assert float(stats["entropy"]) == pytest.approx(float(-logp_pi.mean()), rel=1e-5)
    target_entropy = 0.98 * math.log(2)
    assert float(stats["alpha_loss"]) == pytest.approx(float(-(math.log(0.5) * (logp_pi + target_entropy)).mean()),
                                                       rel=1e-5)


def test_actor_loss_is_the_expectation_and_its_gradient_reaches_the_logits_only():
    model, _ = discrete_model(n=3)
    obs = torch.randn(5, 3)
    logits = model.network.actor(obs)
    q = torch.min(*model.network.critic(obs)).detach()
    logp_pi, q_pi = model.soft_terms(model.network.critic, obs)
    p = torch.softmax(logits, -1)
    by_hand = (p * (0.3 * torch.log_softmax(logits, -1) - q)).sum(-1)
    assert (0.3 * logp_pi - q_pi).tolist() == pytest.approx(by_hand.tolist(), rel=1e-5, abs=1e-6)


def test_greedy_play_is_the_argmax_and_export_value_is_the_twin_minimum_there():
    model, _ = discrete_model(n=3)
    obs = torch.randn(6, 3)
    with torch.no_grad():
        logits, value = model(obs)
        q1, q2 = model.network.critic(obs)
    greedy = model.act(obs, deterministic=True)["actions"].clone()
    assert torch.equal(greedy, logits.argmax(-1)) and greedy.dtype == torch.long
    assert value[:, 0].tolist() == pytest.approx(torch.min(q1, q2).gather(-1, greedy[:, None])[:, 0].tolist())
    assert model.dist.random(100, torch.device("cpu")).unique().tolist() == [0, 1, 2]
    assert isinstance(model, DiscreteSoftActorCritic)


@pytest.mark.parametrize("space", [gym.spaces.MultiDiscrete([2, 3]), gym.spaces.MultiBinary(2)])
def test_other_action_spaces_are_refused_by_the_network_and_the_model(space):
    with pytest.raises(ValueError, match="soft_actor_critic needs Box or Discrete actions"):
        sac_network(SACNetworkConfig(), action_space=space, input_shape=(3,), actions_num=5)
    with pytest.raises(ValueError, match="soft_actor_critic needs Box or Discrete actions"):
        soft_actor_critic_model(None, space, (3,), 1, SACConfig(env_name="x"), "soft_actor_critic")


def test_a_multi_discrete_env_is_a_one_line_error_naming_the_file_and_key(tmp_path):
    with pytest.raises(ConfigError, match=r"sac_cartpole.yaml: params.network: soft_actor_critic needs Box or "
                                          r"Discrete actions, the env has MultiDiscrete") as err:
        Runner().load(os.path.join(CONFIGS, "sac_cartpole.yaml"),
                      ["params.config.env_name=TestMultiDiscrete-v0", f"params.config.train_dir={tmp_path}",
                       "params.config.max_epochs=1"]).train()
    assert "\n" not in str(err.value)


def test_mean_clip_with_discrete_actions_is_refused():
    with pytest.raises(ValueError, match="params.network.mean_clip: .*Discrete actions"):
        sac_network(SACNetworkConfig(mean_clip=2.0), action_space=gym.spaces.Discrete(2), input_shape=(3,),
                    actions_num=2)
