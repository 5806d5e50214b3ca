"""rl_games' ``models``: the model classes that wrap a network builder (``ModelA2C(builder).build(config)``).

``build(config)`` builds the network with ``builder.build(model_class, **config)`` and wraps it in the model's
``Network``: input normalization (``running_mean_std``), value normalization (``value_mean_std``) and the
action distribution, with rl_games' ``forward(input_dict)``: in training (``is_train``) it returns
``prev_neglogp``, ``values``, ``entropy``, ``rnn_states`` and the distribution's parameters; otherwise sampled
``actions``, ``neglogpacs``, denormalized ``values``. They serve user code that builds a model itself;
when a config names one through ``register_model``, rlchain trains the preset of the same family
(:data:`RLCHAIN_PRESETS`) on its own loop.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn as nn
from torch.distributions import Categorical, Normal

from rlchain.models.distributions import sigma_std
from rlchain.rl_games.algos_torch.running_mean_std import RunningMeanStd, RunningMeanStdObs


class BaseModel:
    """A model class: holds the network builder; ``build(config)`` makes ``self.Network`` around the network."""

    Network: type

    def __init__(self, model_class: str) -> None:
        self.model_class = model_class

    def is_rnn(self) -> bool:
        return False

    def is_separate_critic(self) -> bool:
        return False

    def get_value_layer(self) -> nn.Module | None:
        return None

    def build(self, config: dict) -> nn.Module:
        """``config``: ``input_shape``, ``actions_num``, ``value_size``, ``num_seqs``, ``normalize_input``,
        ``normalize_value`` (the network builder gets all of it)."""
        network = self.network_builder.build(self.model_class, **config)
        return self.Network(network, obs_shape=config["input_shape"],
                            normalize_value=config.get("normalize_value", False),
                            normalize_input=config.get("normalize_input", False),
                            value_size=config.get("value_size", 1))


class _BuiltModel(BaseModel):
    """The models below: ``Model(network_builder)``, of rl_games' model class ``_model_class``."""

    _model_class = "a2c"

    def __init__(self, network: Any) -> None:
        BaseModel.__init__(self, self._model_class)
        self.network_builder = network


class BaseModelNetwork(nn.Module):
    """Normalizers shared by the model networks."""

    def __init__(self, obs_shape: Any, normalize_value: bool, normalize_input: bool, value_size: int) -> None:
        super().__init__()
        self.obs_shape = obs_shape
        self.normalize_value = normalize_value
        self.normalize_input = normalize_input
        self.value_size = value_size
        if normalize_value:
            self.value_mean_std = RunningMeanStd((value_size,))
        if normalize_input:
            self.running_mean_std = RunningMeanStdObs(obs_shape) if isinstance(obs_shape, dict) \
                else RunningMeanStd(obs_shape)

    def norm_obs(self, observation: Any) -> Any:
        with torch.no_grad():
            return self.running_mean_std(observation) if self.normalize_input else observation

    def denorm_value(self, value: torch.Tensor) -> torch.Tensor:
        with torch.no_grad():
            return self.value_mean_std(value, denorm=True) if self.normalize_value else value

    def get_aux_loss(self) -> Any:
        return None


class _A2CNetwork(BaseModelNetwork):
    """The network wrapper of the actor-critic models; subclasses give the distribution."""

    def __init__(self, a2c_network: nn.Module, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.a2c_network = a2c_network

    def get_aux_loss(self) -> Any:
        return self.a2c_network.get_aux_loss()

    def is_rnn(self) -> bool:
        return self.a2c_network.is_rnn()

    def get_default_rnn_state(self) -> Any:
        return self.a2c_network.get_default_rnn_state()

    def get_value_layer(self) -> Any:
        return self.a2c_network.get_value_layer()

    def forward(self, input_dict: dict) -> dict:
        is_train = input_dict.get("is_train", True)
        input_dict["obs"] = self.norm_obs(input_dict["obs"])
        out = self.a2c_network(input_dict)
        *head, value, states = out
        dist, params = self.distribution(head, input_dict.get("action_masks", None))
        if is_train:
            prev = input_dict.get("prev_actions", None)
            return {"prev_neglogp": -self.log_prob(dist, prev), "values": value, "entropy": self.entropy(dist),
                    "rnn_states": states, **params}
        actions = self.sample(dist)
        return {"neglogpacs": -self.log_prob(dist, actions), "values": self.denorm_value(value),
                "actions": actions, "rnn_states": states, **params}

    def distribution(self, head: list, masks: Any) -> tuple[Any, dict]:  # pragma: no cover - interface
        raise NotImplementedError

    def log_prob(self, dist: Any, actions: torch.Tensor) -> torch.Tensor:
        return dist.log_prob(actions)

    def entropy(self, dist: Any) -> torch.Tensor:
        return dist.entropy()

    def sample(self, dist: Any) -> torch.Tensor:
        return dist.sample()


def _masked_logits(logits: torch.Tensor, masks: torch.Tensor | None) -> torch.Tensor:
    return logits if masks is None else logits.masked_fill(~masks.bool(), -1e8)


class ModelA2C(_BuiltModel):
    """Discrete actions: a categorical over ``logits`` (invalid actions masked out by ``action_masks``)."""

    class Network(_A2CNetwork):
        def distribution(self, head: list, masks: Any) -> tuple[Any, dict]:
            dist = Categorical(logits=_masked_logits(head[0], masks))
            return dist, {"logits": dist.logits}

        def sample(self, dist: Any) -> torch.Tensor:
            return dist.sample().long()


class ModelA2CMultiDiscrete(_BuiltModel):
    """Multi-discrete actions: one categorical per dimension; log-probs and entropies summed."""

    class Network(_A2CNetwork):
        def distribution(self, head: list, masks: Any) -> tuple[Any, dict]:
            logits = list(head[0])
            if masks is not None:
                masks = torch.split(masks, [lg.shape[-1] for lg in logits], dim=1)
                logits = [_masked_logits(lg, m) for lg, m in zip(logits, masks)]
            dists = [Categorical(logits=lg) for lg in logits]
            return dists, {"logits": [d.logits for d in dists]}

        def log_prob(self, dist: Any, actions: torch.Tensor) -> torch.Tensor:
            return torch.stack([d.log_prob(a) for d, a in zip(dist, actions.unbind(-1))], -1).sum(-1)

        def entropy(self, dist: Any) -> torch.Tensor:
            return torch.stack([d.entropy() for d in dist], -1).sum(-1)

        def sample(self, dist: Any) -> torch.Tensor:
            return torch.stack([d.sample().long() for d in dist], -1)


def apply_sigma_parametrization(raw: torch.Tensor, network: Any) -> tuple[torch.Tensor, torch.Tensor]:
    """(std, log std) from the sigma head's raw output by ``network``'s rl_games 2.0 options
    (``sigma_parametrization``, ``min_sigma``, ``logstd_bounds``; ``scalar`` is ``linear``): :func:`sigma_std`."""
    min_sigma = float(getattr(network, "min_sigma", 0.0))
    kind = getattr(network, "sigma_parametrization", "exp")
    bounds = getattr(network, "logstd_bounds", None)
    sigma = sigma_std(raw, "linear" if kind == "scalar" else kind, min_sigma, bounds)
    if kind not in ("softplus", "linear", "scalar") and min_sigma <= 0:  # exp: the (clamped) raw is the log std
        return sigma, raw if bounds is None else raw.clamp(bounds[0], bounds[1])
    return sigma, sigma.log()


class ModelA2CContinuous(_BuiltModel):
    """Continuous actions, the network's ``sigma`` taken as the standard deviation."""

    class Network(_A2CNetwork):
        log_std = False

        def distribution(self, head: list, masks: Any) -> tuple[Any, dict]:
            mu, sigma = head
            std = apply_sigma_parametrization(sigma, self.a2c_network)[0] if self.log_std else sigma
            return Normal(mu, std), {"mus": mu, "sigmas": std}

        def log_prob(self, dist: Any, actions: torch.Tensor) -> torch.Tensor:
            return dist.log_prob(actions).sum(-1)

        def entropy(self, dist: Any) -> torch.Tensor:
            return dist.entropy().sum(-1)


class ModelA2CContinuousLogStd(ModelA2CContinuous):
    """Continuous actions, the network's ``sigma`` mapped to the standard deviation by
    :func:`apply_sigma_parametrization` (by default: taken as the log standard deviation)."""

    class Network(ModelA2CContinuous.Network):
        log_std = True


class ModelCentralValue(_BuiltModel):
    """A value-only critic: ``forward`` returns ``values`` (denormalized outside training) and ``rnn_states``."""

    class Network(_A2CNetwork):
        def forward(self, input_dict: dict) -> dict:
            is_train = input_dict.get("is_train", True)
            input_dict["obs"] = self.norm_obs(input_dict["obs"])
            value, states = self.a2c_network(input_dict)
            return {"values": value if is_train else self.denorm_value(value), "rnn_states": states}


class ModelSACContinuous(_BuiltModel):
    """SAC: the network (actor, critic, critic_target) with rl_games' accessors."""

    _model_class = "sac"

    class Network(BaseModelNetwork):
        def __init__(self, sac_network: nn.Module, **kwargs: Any) -> None:
            super().__init__(**kwargs)
            self.sac_network = sac_network

        def critic(self, obs: torch.Tensor, action: torch.Tensor) -> Any:
            return self.sac_network.critic(obs, action)

        def critic_target(self, obs: torch.Tensor, action: torch.Tensor) -> Any:
            return self.sac_network.critic_target(obs, action)

        def actor(self, obs: torch.Tensor) -> Any:
            return self.sac_network.actor(obs)

        def is_rnn(self) -> bool:
            return False

        def forward(self, input_dict: dict) -> Any:
            return self.sac_network(input_dict)


RLCHAIN_PRESETS: dict[type, str] = {
    ModelA2C: "discrete_a2c", ModelA2CMultiDiscrete: "multi_discrete_a2c", ModelA2CContinuousLogStd:
    "continuous_a2c_logstd", ModelA2CContinuous: "continuous_a2c", ModelSACContinuous: "soft_actor_critic",
}
"""The rlchain model preset that trains a config naming a subclass of each rl_games model class."""


def rlchain_preset(model: Any) -> str | None:
    """The preset of the most derived rl_games model class ``model`` (a class or an instance) extends, or None."""
    cls = model if isinstance(model, type) else type(model)
    for base in cls.__mro__:
        if base in RLCHAIN_PRESETS:
            return RLCHAIN_PRESETS[base]
    return None


__all__ = ["BaseModel", "BaseModelNetwork", "ModelA2C", "ModelA2CMultiDiscrete", "ModelA2CContinuous",
           "ModelA2CContinuousLogStd", "ModelCentralValue", "ModelSACContinuous", "apply_sigma_parametrization",
           "RLCHAIN_PRESETS", "rlchain_preset"]
