"""SB3 users' classes on rlchain, the plumbing: the extractors (NatureCNN, CombinedExtractor), the adapter that
hands them observations as SB3 does, the ActorCriticPolicy contract, class names in a config, and which policy
arguments build the sb3_policy network."""

import gymnasium as gym
import numpy as np
import pytest
import torch
from torch import nn

from rlchain.networks.sb3_extractors import BaseFeaturesExtractor, CombinedExtractor, NatureCNN, channels_first_space
from rlchain.networks.sb3_policies import ActorCriticPolicy
from rlchain.networks.sb3_policy import ObsAdapter, SB3ActorCriticNetwork, sb3_policy_network
from rlchain.networks.user_classes import class_name, remember, resolve
from rlchain.sb3.policy_block import needs_sb3_network, sb3_network_block

IMAGE = gym.spaces.Box(0, 255, (36, 36, 3), np.uint8)


class Tiny(BaseFeaturesExtractor):
    """A user extractor: a linear layer of ``features_dim``."""

    def __init__(self, observation_space, features_dim=8):
        super().__init__(observation_space, features_dim)
        self.linear = nn.Linear(int(np.prod(observation_space.shape)), features_dim)

    def forward(self, obs):
        return self.linear(obs.flatten(1))


class TwoHeads(nn.Module):
    """An mlp_extractor of SB3's contract with different actor and critic widths."""

    def __init__(self, feature_dim):
        super().__init__()
        self.latent_dim_pi, self.latent_dim_vf = 5, 3
        self.pi, self.vf = nn.Linear(feature_dim, 5), nn.Linear(feature_dim, 3)

    def forward(self, features):
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features):
        return self.pi(features)

    def forward_critic(self, features):
        return self.vf(features)


class OwnPolicy(ActorCriticPolicy):
    def _build_mlp_extractor(self):
        self.mlp_extractor = TwoHeads(self.features_dim)


def test_nature_cnn_takes_channel_first_images_to_features_dim():
    cnn = NatureCNN(channels_first_space(IMAGE), features_dim=16)
    assert cnn(torch.zeros(2, 3, 36, 36)).shape == (2, 16)
    with pytest.raises(ValueError, match="NatureCNN needs image observations"):
        NatureCNN(gym.spaces.Box(-1, 1, (4,)))


def test_the_adapter_transposes_channel_last_images_and_one_hots_discrete_keys():
    space = gym.spaces.Dict({"img": IMAGE, "step": gym.spaces.Discrete(4), "vec": gym.spaces.Box(-1, 1, (2,))})
    adapter = ObsAdapter(space)
    assert adapter.extractor_space["img"].shape == (3, 36, 36) and adapter.extractor_space["vec"].shape == (2,)
    image = torch.rand(2, 36, 36, 3)
    out = adapter({"img": image, "step": torch.tensor([1, 3]), "vec": torch.zeros(2, 2)})
    assert torch.equal(out["img"], image.permute(0, 3, 1, 2))
    assert torch.equal(out["step"], torch.tensor([[0.0, 1, 0, 0], [0, 0, 0, 1]]))
    raw = ObsAdapter(IMAGE, normalize_images=False)(torch.full((1, 36, 36, 3), 0.5))
    assert raw.shape == (1, 3, 36, 36) and float(raw.max()) == 127.5  # SB3 scales only with normalize_images
    flat = ObsAdapter(IMAGE)(image.reshape(2, -1))  # a model that flattens (SAC, DQN): the shape comes back
    assert torch.equal(flat, image.permute(0, 3, 1, 2))


def test_combined_extractor_sizes_a_cnn_per_image_and_flattens_the_rest():
    space = gym.spaces.Dict({"img": channels_first_space(IMAGE), "vec": gym.spaces.Box(-1, 1, (2,))})
    extractor = CombinedExtractor(space, cnn_output_dim=7)
    assert extractor.features_dim == 9
    assert extractor({"img": torch.zeros(3, 3, 36, 36), "vec": torch.zeros(3, 2)}).shape == (3, 9)


def test_a_policy_class_with_its_own_mlp_extractor_drives_the_network():
    box = gym.spaces.Box(-1, 1, (4,), np.float32)
    policy = OwnPolicy(box, gym.spaces.Box(-1, 1, (2,), np.float32), lambda p: 0.0,
                       features_extractor_class=Tiny, share_features_extractor=False)
    assert policy.pi_features_extractor is not policy.vf_features_extractor
    assert policy.action_net.in_features == 5 and policy.value_net.in_features == 3
    net = SB3ActorCriticNetwork(ObsAdapter(box), policy, continuous=True)
    mu, log_std, value, states = net({"obs": torch.zeros(6, 4)})
    assert mu.shape == log_std.shape == (6, 2) and value.shape == (6, 1) and states is None


def test_the_builder_makes_sac_and_dqn_networks_around_an_extractor():
    remember(Tiny)
    box = gym.spaces.Box(-1, 1, (4,), np.float32)
    block = sb3_network_block("sac", "MlpPolicy", {"features_extractor_class": Tiny, "net_arch": {"pi": [8],
                                                                                                   "qf": [16, 16]}})
    sac = sb3_policy_network(block, observation_space=box, input_shape=(4,), actions_num=2,
                             action_space=gym.spaces.Box(-1, 1, (2,), np.float32))
    assert sac.actor.encoder is not sac.critic.encoder  # SB3's SAC: an extractor each
    assert sac.critic.Q1[0].out_features == 16 and sac.actor.trunk[0].out_features == 8
    dqn = sb3_policy_network(sb3_network_block("dqn", "CnnPolicy", {}), observation_space=IMAGE,
                             input_shape=IMAGE.shape, actions_num=3, action_space=gym.spaces.Discrete(3))
    assert dqn(torch.zeros(2, 36, 36, 3)).shape == (2, 3)


def test_classes_are_stored_by_name_and_found_only_among_those_defined():
    assert remember(Tiny) == class_name(Tiny) and resolve(class_name(Tiny), "k") is Tiny
    assert resolve(class_name(OwnPolicy), "policy") is OwnPolicy  # a subclass of a known base, defined here
    with pytest.raises(ValueError, match="class 'os.system' is not defined in this process"):
        resolve("os.system", "features_extractor_class")


def test_which_arguments_build_the_sb3_network():
    assert not needs_sb3_network("ppo", "MlpPolicy", {"net_arch": {"pi": [8], "vf": [4]}})
    assert needs_sb3_network("ppo", "CnnPolicy", {}) and needs_sb3_network("ppo", OwnPolicy, {})
    assert needs_sb3_network("sac", "MlpPolicy", {"net_arch": {"pi": [8], "qf": [4]}})
    assert needs_sb3_network("dqn", "MlpPolicy", {"features_extractor_class": Tiny})
    block = sb3_network_block("ppo", "CnnPolicy", {"activation_fn": nn.ReLU})
    assert block["policy_kwargs"] == {"activation_fn": "ReLU", "features_extractor_class": "NatureCNN",
                                      "net_arch": []}
    with pytest.raises(ValueError, match="optimizer_class: has no rlchain counterpart"):
        sb3_network_block("ppo", "MlpPolicy", {"optimizer_class": torch.optim.RMSprop})
    with pytest.raises(ValueError, match="a policy class is taken for PPO"):
        sb3_network_block("sac", OwnPolicy, {})
