"""The ``resnet_actor_critic`` network (rl_games' name): IMPALA encoder -> mlp / rnn -> heads.

Observations are either an image, (B, C, H, W) or channels-last with ``cnn.permute_input`` (uint8
images reach the network scaled to [0, 1] by the model), or the flat vector of rl_games' Dict
``{'observation', 'reward', 'last_action'}`` that rlchain/envs/wrappers/reward_action_obs.py makes
(``use_dict_obs_space`` / ``wrap_impala``). Its observation space then carries ``dict_space``, the
layout, which this network reads from the builder's ``observation_space`` (duck-typed: networks do
not import envs). The image part goes through the encoder; with ``require_rewards`` /
``require_last_actions`` the reward (B, 1) and the one-hot last action (B, n), in that order, join
the recurrent layer's input as in rl_games (the MLP's when there is no ``rnn``; rl_games then drops
them). The rest (heads, separate critic, RNN states) is :class:`ActorCriticNetwork`'s.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import torch
import torch.nn as nn

from rlchain.config.network import ResnetNetworkConfig
from rlchain.networks.actor_critic import ActorCriticNetwork, is_continuous
from rlchain.networks.impala import ImpalaEncoder

EXTRA_KEYS = (("reward", "require_rewards"), ("last_action", "require_last_actions"))
"""Inputs besides the image, in the order they join the features, and the key asking for each."""
DICT_OBS_HINT = ("set params.config.env_config.use_dict_obs_space: True (env_name envpool) or "
                 "wrap_impala: True (env_name atari_gym)")


def flat_layout(space: Any) -> dict[str, tuple[slice, tuple[int, ...]]] | None:
    """{key: (columns, shape)} of a flattened Dict observation space, else None. ``space`` is the
    env's Dict itself (what the network builders get, see ``training.build.declared_space``) or a
    flat space that carries it as ``dict_space``."""
    dict_space = space if isinstance(space, gym.spaces.Dict) else getattr(space, "dict_space", None)
    if not isinstance(dict_space, gym.spaces.Dict):
        return None
    layout, start = {}, 0
    for key, sub in dict_space.spaces.items():
        size = int(gym.spaces.flatdim(sub))
        shape = tuple(sub.shape) if isinstance(sub, gym.spaces.Box) else (size,)
        layout[key] = (slice(start, start + size), shape)
        start += size
    return layout


class ResnetActorCriticNetwork(ActorCriticNetwork):
    """rl_games' tuple ``(logits, value, states)`` / ``(mu, sigma, value, states)`` from images or flat
    Dict observations (see the module docstring); shapes as :class:`ActorCriticNetwork`. rl_games names this
    network's encoder ``cnn`` and its MLP ``mlp``."""

    CNN, MLP_NAME = ("cnn", "critic_cnn"), ("mlp", "critic_mlp")

    def __init__(self, cfg: ResnetNetworkConfig, input_shape: tuple[int, ...], actions_num: int,
                 value_size: int, continuous: bool, observation_space: Any = None) -> None:
        layout = flat_layout(observation_space)
        wanted = [key for key, flag in EXTRA_KEYS if getattr(cfg, flag)]
        missing = [key for key in wanted if layout is None or key not in layout]
        if layout is not None and "observation" not in layout:
            raise ValueError(f"params.network: resnet_actor_critic needs an 'observation' entry in the Dict "
                             f"observations, the env has {sorted(layout)}")
        if missing:
            flag = dict(EXTRA_KEYS)[missing[0]]
            raise ValueError(f"params.network.{flag}: needs the previous {missing[0].replace('_', ' ')} in the "
                             f"observations: {DICT_OBS_HINT}; the env gives observations of shape "
                             f"{tuple(input_shape)}")
        image_shape = layout["observation"][1] if layout is not None else tuple(input_shape)
        extra_size = sum(layout[key][0].stop - layout[key][0].start for key in wanted) if wanted else 0

        def make_encoder() -> ImpalaEncoder:
            # rl_games: mlp.activation on the flattened features, whatever cnn.activation says
            return ImpalaEncoder(cfg.cnn, image_shape, cfg.mlp.activation)

        super().__init__(cfg, image_shape, actions_num, value_size, continuous, make_encoder, extra_size)
        self.image_columns = layout["observation"][0] if layout is not None else None
        self.image_shape = image_shape
        self.extra_columns = [layout[key][0] for key in wanted]

    def split_obs(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """obs (B, flat) -> (image (B, *image_shape), extras (B, extra_size) or None); an image passes."""
        if self.image_columns is None:
            return obs, None
        image = obs[:, self.image_columns].reshape(obs.shape[0], *self.image_shape)
        if not self.extra_columns:
            return image, None
        return image, torch.cat([obs[:, cols] for cols in self.extra_columns], -1)


def resnet_actor_critic_network(cfg: ResnetNetworkConfig, **kwargs: Any) -> nn.Module:
    """The network registered as ``resnet_actor_critic`` (its block parses into ``config_class``)."""
    continuous = is_continuous(cfg, kwargs["action_space"])
    return ResnetActorCriticNetwork(cfg, tuple(kwargs["input_shape"]), kwargs["actions_num"],
                                    kwargs.get("value_size", 1), continuous, kwargs.get("observation_space"))


resnet_actor_critic_network.config_class = ResnetNetworkConfig
