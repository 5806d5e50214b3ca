"""The ``sb3_policy`` network: Stable-Baselines3 users' own classes (feature extractors, policy classes) on
rlchain's loop.

The network block (written by the SB3 face from ``policy`` and ``policy_kwargs``; plain data)::

    network:
      name: sb3_policy
      algo: ppo                    # ppo (an ActorCriticPolicy), sac (actor + twin critics), dqn (a Q-network)
      policy_class: null           # PPO: 'module.QualName' of an ActorCriticPolicy subclass; null: rlchain's own
      policy_kwargs:               # the policy's constructor arguments, classes by name
        features_extractor_class: __main__.CustomCNN
        features_extractor_kwargs: {features_dim: 128}
        net_arch: {pi: [64, 64], vf: [64, 64]}
        activation_fn: Tanh
      log_std_bounds: [-20, 2]     # sac
      dueling: false               # dqn

Classes are looked up by name among those this process holds (:mod:`rlchain.networks.user_classes`). What the
extractors see is what SB3 gives them: uint8 images in [0, 1] (the model divides by 255; with
``normalize_images: False`` they get the raw 0..255 values), channel-last images transposed to channel-first (as
SB3's ``VecTransposeImage`` does; the extractor is built for the transposed space), Discrete entries one-hot.
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from rlchain.config.network import MlpConfig
from rlchain.networks.layers import linear
from rlchain.networks.mlp import MLP
from rlchain.networks.sac_network import SACActor, TwinQCritic
from rlchain.networks.sb3_extractors import (
    CombinedExtractor,
    FlattenExtractor,
    NatureCNN,
    channels_first_space,
    is_channels_first,
    is_image_space,
    split_net_arch,
)
from rlchain.networks.sb3_policies import ActorCriticPolicy
from rlchain.networks.user_classes import resolve

TORCH_TO_RL_GAMES = {"relu": "relu", "tanh": "tanh", "elu": "elu", "selu": "selu", "silu": "swish", "swish": "swish",
                     "gelu": "gelu", "softplus": "softplus", "sigmoid": "sigmoid", "identity": "None"}
"""torch.nn activation class names (lower case) -> rl_games' activation names."""

BUILT_IN = {"FlattenExtractor": FlattenExtractor, "NatureCNN": NatureCNN, "CombinedExtractor": CombinedExtractor,
            "ActorCriticPolicy": ActorCriticPolicy}
"""Classes a block may name by their short name (SB3's defaults)."""


def find_class(name: Any, key: str) -> Any:
    """A class from its name in a block (a built-in short name, or a class this process holds)."""
    if name is None or isinstance(name, type):
        return name
    return BUILT_IN.get(str(name)) or resolve(str(name), key)


def torch_activation(name: Any) -> type[nn.Module]:
    """A torch.nn activation class from its class name (``'ReLU'``)."""
    if isinstance(name, type):
        return name
    cls = getattr(nn, str(name), None)
    if not (isinstance(cls, type) and issubclass(cls, nn.Module)):
        raise ValueError(f"params.network.policy_kwargs.activation_fn: '{name}' is not a torch.nn activation")
    return cls


class ObsAdapter(nn.Module):
    """Observations as rlchain's model hands them (floats; images in [0, 1] as they come) -> as SB3's extractors
    take them (channel-first images, one-hot Discrete entries). ``space``: the env's space (a Box or a Dict);
    ``extractor_space`` is what the extractor is built for."""

    def __init__(self, space: gym.Space, normalize_images: bool = True) -> None:
        super().__init__()
        self.space = space
        self.scale = 1.0 if normalize_images else 255.0
        spaces = space.spaces if isinstance(space, gym.spaces.Dict) else {"": space}
        self.plans = {key: self._plan(sub) for key, sub in spaces.items()}
        converted = {key: self._converted(sub, self.plans[key]) for key, sub in spaces.items()}
        self.extractor_space = gym.spaces.Dict(converted) if isinstance(space, gym.spaces.Dict) else converted[""]

    @staticmethod
    def _plan(space: gym.Space) -> tuple[str, Any, tuple[int, ...]]:
        """(kind, detail, the space's shape): an image's axis order (None: channel-first already), a Discrete /
        MultiDiscrete's sizes."""
        shape = tuple(space.shape or ())
        if is_image_space(space):
            return ("image", None if is_channels_first(space) else (0, 3, 1, 2), shape)
        if isinstance(space, gym.spaces.Discrete):
            return ("discrete", [int(space.n)], shape)
        if isinstance(space, gym.spaces.MultiDiscrete):
            return ("discrete", [int(n) for n in np.asarray(space.nvec).ravel()], shape)
        return ("box", None, shape)

    @staticmethod
    def _converted(space: gym.Space, plan: tuple[str, Any, tuple[int, ...]]) -> gym.Space:
        if plan[0] == "image" and plan[1] is not None:
            return channels_first_space(space)
        return space

    def _one(self, x: torch.Tensor, plan: tuple[str, Any, tuple[int, ...]]) -> torch.Tensor:
        kind, detail, shape = plan
        if kind == "discrete":
            index = x.reshape(x.shape[0], -1)
            if index.shape[1] == len(detail):  # indices (rlchain keeps Discrete keys as indices)
                return torch.cat([F.one_hot(index[:, i].long(), n).float() for i, n in enumerate(detail)], dim=1)
            return x.float()  # one-hot already (a flattened observation)
        if x.dim() == 2 and len(shape) > 1:  # a model that flattens its input (SAC, DQN): the shape back
            x = x.reshape(x.shape[0], *shape)
        if kind == "image":
            if detail is not None:
                x = x.permute(*detail)
            return x * self.scale if self.scale != 1.0 else x
        return x

    def forward(self, obs: Any) -> Any:
        if isinstance(self.space, gym.spaces.Dict):
            return {key: self._one(obs[key], plan) for key, plan in self.plans.items()}
        return self._one(obs, self.plans[""])


class ExtractorEncoder(nn.Module):
    """An SB3 features extractor behind its :class:`ObsAdapter`: obs -> (B, ``out_size``) features."""

    def __init__(self, adapter: ObsAdapter, extractor: nn.Module) -> None:
        super().__init__()
        self.adapter = adapter
        self.extractor = extractor
        self.out_size = int(extractor.features_dim)

    def forward(self, obs: Any) -> torch.Tensor:
        return self.extractor(self.adapter(obs))


class SB3ActorCriticNetwork(nn.Module):
    """An ActorCriticPolicy (rlchain's or a subclass of SB3's: the parts its contract names) as rlchain's
    actor-critic network: returns ``(logits, value, None)`` or ``(mu, log_std, value, None)``."""

    def __init__(self, adapter: ObsAdapter, policy: nn.Module, continuous: bool) -> None:
        super().__init__()
        self.adapter = adapter
        self.policy = policy
        self.continuous = continuous

    def latents(self, obs: Any) -> tuple[torch.Tensor, torch.Tensor]:
        """(latent_pi, latent_vf) of the policy's extractor(s) and mlp_extractor."""
        x = self.adapter(obs)
        policy = self.policy
        if getattr(policy, "share_features_extractor", True):
            return policy.mlp_extractor(policy.features_extractor(x))
        return (policy.mlp_extractor.forward_actor(policy.pi_features_extractor(x)),
                policy.mlp_extractor.forward_critic(policy.vf_features_extractor(x)))

    def forward(self, input_dict: dict[str, Any]) -> tuple:
        latent_pi, latent_vf = self.latents(input_dict["obs"])
        value = self.policy.value_net(latent_vf)
        out = self.policy.action_net(latent_pi)
        if not self.continuous:
            return out, value, None
        return out, self.policy.log_std.expand_as(out), value, None

    def is_rnn(self) -> bool:
        return False


class SharedExtractorCritic(TwinQCritic):
    """SAC's twin critic reading the actor's extractor (SB3's ``share_features_extractor=True``): the features are
    computed without gradient, so only the actor's loss trains the extractor, as SB3's ``ContinuousCritic`` does
    (its critic optimizer leaves the shared extractor out; here the extractor gets no gradient from the critic's
    loss, so the critic's Adam skips it). ``requires_grad_`` (the SAC update freezes the critic during the actor's
    step) leaves the shared extractor alone. Copied on its own (the target critic), it becomes a plain
    :class:`TwinQCritic` with an extractor of its own, Polyak-averaged from the shared one as SB3's target is;
    copied with the network that owns the extractor, it stays shared."""

    def forward(self, obs: Any, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        with torch.no_grad():
            features = self.encoder(obs)
        x = torch.cat([features, actions], dim=-1)
        return self.Q1(x).squeeze(-1), self.Q2(x).squeeze(-1)

    def requires_grad_(self, requires_grad: bool = True) -> SharedExtractorCritic:
        self.Q1.requires_grad_(requires_grad)
        self.Q2.requires_grad_(requires_grad)
        return self

    def __deepcopy__(self, memo: dict[int, Any]) -> nn.Module:
        shared = id(self.encoder) in memo  # the owner (the actor) was copied first: keep sharing its copy
        copied = TwinQCritic.__new__(SharedExtractorCritic if shared else TwinQCritic)
        memo[id(self)] = copied
        for key, value in self.__dict__.items():  # nn.Module's state: _modules, _parameters, hooks, ...
            copied.__dict__[key] = copy.deepcopy(value, memo)
        return copied


class SB3SACNetwork(nn.Module):
    """SAC with SB3's extractors: ``actor`` and ``critic`` (twin Q), hidden sizes ``pi`` and ``qf``. Each reads the
    observations through an extractor of its own (SB3's SAC default, ``share_features_extractor=False``), or, with
    ``share``, the critic reads the actor's (:class:`SharedExtractorCritic`)."""

    def __init__(self, make_encoder: Any, actions_num: int, pi: MlpConfig, qf: MlpConfig,
                 log_std_bounds: list[float], share: bool = False) -> None:
        super().__init__()
        self.actor = SACActor(0, actions_num, pi, log_std_bounds, None, make_encoder())
        self.critic = SharedExtractorCritic(0, actions_num, qf, self.actor.encoder) if share \
            else TwinQCritic(0, actions_num, qf, make_encoder())

    def forward(self, input_dict: dict[str, Any]) -> tuple:
        mu, log_std = self.actor(input_dict["obs"])
        return mu, log_std, None, None

    def is_rnn(self) -> bool:
        return False


class SB3QNetwork(nn.Module):
    """DQN's Q-network with an SB3 extractor: obs -> features -> MLP -> Q-values (dueling when asked)."""

    def __init__(self, encoder: ExtractorEncoder, actions_num: int, mlp: MlpConfig, dueling: bool) -> None:
        super().__init__()
        self.encoder = encoder
        self.trunk = MLP(encoder.out_size, mlp)
        self.advantage = linear(self.trunk.out_size, actions_num, mlp.initializer)
        self.state_value = linear(self.trunk.out_size, 1, mlp.initializer) if dueling else None

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        h = self.trunk(self.encoder(obs))
        adv = self.advantage(h)
        return adv if self.state_value is None else self.state_value(h) + adv - adv.mean(-1, keepdim=True)

    def is_rnn(self) -> bool:
        return False


def constant_lr(progress_remaining: float) -> float:
    """The ``lr_schedule`` a policy class's constructor takes (rlchain's optimizer has its own)."""
    return 0.0


def _mlp(units: list[int], activation: type[nn.Module]) -> MlpConfig:
    name = TORCH_TO_RL_GAMES.get(activation.__name__.lower())
    if name is None:
        raise ValueError(f"params.network.policy_kwargs.activation_fn: {activation.__name__} has no rl_games "
                         f"activation (choices: {', '.join(sorted(TORCH_TO_RL_GAMES))})")
    return MlpConfig(units=list(units), activation=name)


def _adapter_and_default(space: gym.Space, kwargs: dict[str, Any]) -> tuple[ObsAdapter, Any]:
    """The adapter for ``space`` and the default extractor class (Dict: CombinedExtractor; an image: NatureCNN
    when the block asks for ``cnn``, else FlattenExtractor)."""
    adapter = ObsAdapter(space, bool(kwargs.get("normalize_images", True)))
    default = CombinedExtractor if isinstance(space, gym.spaces.Dict) else FlattenExtractor
    return adapter, default


def sb3_policy_network(block: Any, **kwargs: Any) -> nn.Module:
    """The network registered as ``sb3_policy`` (see the module docstring); takes Dict observations per key."""
    algo = str(block.get("algo", "ppo"))
    space = kwargs["observation_space"]
    if not isinstance(space, gym.spaces.Dict):
        space = gym.spaces.Box(-np.inf, np.inf, tuple(kwargs["input_shape"]), np.float32) \
            if not isinstance(space, gym.spaces.Box) or tuple(space.shape) != tuple(kwargs["input_shape"]) \
            else space
    policy_kwargs = dict(block.get("policy_kwargs") or {})
    adapter, default = _adapter_and_default(space, policy_kwargs)
    key = "params.network.policy_kwargs.features_extractor_class"
    extractor_class = find_class(policy_kwargs.pop("features_extractor_class", None), key) or default
    extractor_kwargs = dict(policy_kwargs.pop("features_extractor_kwargs", None) or {})
    activation = torch_activation(policy_kwargs.pop("activation_fn", "ReLU" if algo != "ppo" else "Tanh"))
    action_space = kwargs["action_space"]
    policy_class = find_class(block.get("policy_class"), "params.network.policy_class") or ActorCriticPolicy
    if algo == "ppo":
        policy = policy_class(adapter.extractor_space, action_space, constant_lr, activation_fn=activation,
                              features_extractor_class=extractor_class,
                              features_extractor_kwargs=extractor_kwargs, **policy_kwargs)
        return SB3ActorCriticNetwork(adapter, policy, isinstance(action_space, gym.spaces.Box))

    def make_encoder() -> ExtractorEncoder:
        return ExtractorEncoder(copy.deepcopy(adapter),
                                extractor_class(adapter.extractor_space, **extractor_kwargs))

    net_arch = policy_kwargs.pop("net_arch", None)
    policy_kwargs.pop("normalize_images", None)
    share = policy_kwargs.pop("share_features_extractor", False)
    if policy_kwargs:
        raise ValueError(f"params.network.policy_kwargs: {', '.join(policy_kwargs)} not taken by {algo.upper()}'s "
                         f"policy here (net_arch, activation_fn, features_extractor_class / _kwargs, "
                         f"normalize_images)")
    if algo == "sac":
        pi, qf = split_net_arch(net_arch if net_arch is not None else [256, 256], "qf")
        return SB3SACNetwork(make_encoder, kwargs["actions_num"], _mlp(pi, activation), _mlp(qf, activation),
                             list(block.get("log_std_bounds", [-20.0, 2.0])), bool(share))
    if "share_features_extractor" in (block.get("policy_kwargs") or {}):
        raise ValueError("params.network.policy_kwargs.share_features_extractor: DQN's Q-network has one extractor "
                         "(SB3's DQNPolicy takes no share_features_extractor); remove it")
    units = list(net_arch) if net_arch is not None else [64, 64]
    return SB3QNetwork(make_encoder(), kwargs["actions_num"], _mlp(units, activation),
                       bool(block.get("dueling", False)))


sb3_policy_network.takes_dict_obs = True
