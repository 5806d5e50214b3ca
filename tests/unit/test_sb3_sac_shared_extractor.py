"""SAC with ``share_features_extractor=True`` (rlchain/networks/sb3_policy.py): the critic reads the actor's
extractor without training it, the target critic gets a copy of its own, and a copy of the whole network keeps
the sharing."""

import copy

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

from rlchain.networks.sac_network import TwinQCritic
from rlchain.networks.sb3_policy import SharedExtractorCritic, sb3_policy_network
from rlchain.networks.user_classes import remember
from rlchain.sb3.policy_block import sb3_network_block

BOX = gym.spaces.Box(-1, 1, (4,), np.float32)
ACTIONS = gym.spaces.Box(-1, 1, (2,), np.float32)


class Small(nn.Module):
    def __init__(self, observation_space, features_dim=6):
        super().__init__()
        self.features_dim = features_dim
        self.net = nn.Sequential(nn.Linear(observation_space.shape[0], features_dim), nn.ReLU())

    def forward(self, observations):
        return self.net(observations)


def build(algo: str = "sac", **policy_kwargs):
    remember(Small)
    block = sb3_network_block(algo, "MlpPolicy", {"features_extractor_class": Small, **policy_kwargs})
    space = ACTIONS if algo == "sac" else gym.spaces.Discrete(3)
    return sb3_policy_network(block, observation_space=BOX, input_shape=(4,), actions_num=2 if algo == "sac" else 3,
                              action_space=space)


def extractor_grads(net):
    return [p.grad for p in net.actor.encoder.parameters()]


def test_shared_the_critic_reads_the_actors_extractor_and_separate_is_the_default():
    shared = build(share_features_extractor=True)
    assert isinstance(shared.critic, SharedExtractorCritic) and shared.critic.encoder is shared.actor.encoder
    separate = build()
    assert type(separate.critic) is TwinQCritic and separate.critic.encoder is not separate.actor.encoder


def test_the_critics_loss_leaves_the_shared_extractor_without_gradient():
    net = build(share_features_extractor=True)
    q1, q2 = net.critic(torch.randn(5, 4), torch.randn(5, 2))
    (q1 + q2).sum().backward()
    assert all(g is None for g in extractor_grads(net))
    assert all(p.grad is not None for p in net.critic.Q1.parameters())


def test_the_actors_loss_trains_the_extractor_while_the_critic_is_frozen():
    net = build(share_features_extractor=True)
    obs = torch.randn(5, 4)
    net.critic.requires_grad_(False)  # what the SAC update does during the actor's step
    assert all(p.requires_grad for p in net.actor.encoder.parameters())
    mu, _ = net.actor(obs)
    q1, _ = net.critic(obs, torch.tanh(mu))
    q1.sum().backward()
    assert all(g is not None and g.abs().sum() > 0 for g in extractor_grads(net))
    assert all(p.grad is None for p in net.critic.Q1.parameters())
    net.critic.requires_grad_(True)
    assert all(p.requires_grad for p in net.critic.parameters())


def test_the_target_critic_is_a_plain_copy_with_its_own_extractor_aligned_for_polyak():
    net = build(share_features_extractor=True)
    target = copy.deepcopy(net.critic)  # how the SAC model makes its target critic
    assert type(target) is TwinQCritic and target.encoder is not net.actor.encoder
    names = [n for n, _ in net.critic.named_parameters()]
    assert names == [n for n, _ in target.named_parameters()] and names[0].startswith("encoder.")
    for mine, theirs in zip(net.critic.parameters(), target.parameters()):
        assert torch.equal(mine, theirs) and mine.data_ptr() != theirs.data_ptr()
    obs, actions = torch.randn(3, 4), torch.randn(3, 2)
    torch.testing.assert_close(target(obs, actions), net.critic(obs, actions))


def test_a_copy_of_the_whole_network_keeps_the_sharing():
    net = build(share_features_extractor=True)
    clone = copy.deepcopy(net)
    assert isinstance(clone.critic, SharedExtractorCritic) and clone.critic.encoder is clone.actor.encoder
    assert clone.actor.encoder is not net.actor.encoder


def test_dqn_refuses_share_features_extractor_as_sb3_does():
    with pytest.raises(ValueError, match="share_features_extractor: DQN's Q-network has one extractor"):
        build("dqn", share_features_extractor=True)
