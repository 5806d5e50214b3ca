"""rl_games' ``model_builder``: ``register_network`` / ``register_model`` (filling rlchain's registries),
``NetworkBuilder`` and ``ModelBuilder`` (building from a params dict, as rl_games' agents do).

As in rl_games, ``register_network(name, target)`` takes a builder class or any callable returning a builder
(``lambda **kwargs: MyBuilder()``): rlchain calls ``target()``, then ``load(params.network)`` and
``build('a2c', actions_num=..., input_shape=..., value_size=..., num_seqs=..., ...)`` (``actions_num`` a list
of sizes for multi-discrete actions, as rl_games passes it). ``register_model(name, target)`` takes a model
class or a callable called as ``target(network)``: a model deriving one of rl_games' model classes
(:mod:`rlchain.rl_games.algos_torch.models`) trains as rlchain's preset of its family; an rlchain model
(``act`` / ``evaluate``) is used as returned.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rlchain import model_builder as _model_builder
from rlchain.models.distributions import multi_discrete_dims
from rlchain.registry import MODELS
from rlchain.rl_games.algos_torch import models, network_builder
from rlchain.rl_games.common.object_factory import ObjectFactory

NETWORK_REGISTRY: dict[str, Any] = {}
MODEL_REGISTRY: dict[str, Any] = {}


def rl_games_build_kwargs(kwargs: dict) -> dict:
    """rlchain's build kwargs as rl_games passes them: ``actions_num`` per dimension for multi-discrete spaces."""
    dims = multi_discrete_dims(kwargs["action_space"]) if kwargs.get("action_space") is not None else None
    if dims is not None:
        kwargs = {**kwargs, "actions_num": list(dims[0])}
    # SAC's builders read the flat sizes
    return {"obs_dim": int(np.prod(kwargs["input_shape"])), "action_dim": kwargs["actions_num"], **kwargs}


def network_factory(target: Any) -> Any:
    """rlchain's builder function for an rl_games builder ``target`` (a class or a callable returning one)."""
    def build(params: Any, **kwargs: Any) -> Any:
        builder = target()
        builder.load(params)
        return builder.build("a2c", **rl_games_build_kwargs(kwargs))

    build.rl_games_target = target
    return build


def register_network(name: str, target_class: Any) -> None:
    """Make ``params.network.name: <name>`` build with ``target_class()`` (replacing any earlier one)."""
    NETWORK_REGISTRY[name] = lambda **kwargs: target_class()
    _model_builder.register_network(name, network_factory(target_class), overwrite=True,
                                    config_class=getattr(target_class, "config_class", None))


def model_factory(name: str, target: Any) -> Any:
    """rlchain's model factory for an rl_games model ``target`` called as ``target(network)``."""
    def build(network: Any, **kwargs: Any) -> Any:
        model = target(network)
        preset = models.rlchain_preset(model)
        if preset is not None:
            return MODELS.get(preset)(network=network, **{**kwargs, "model_name": preset})
        if callable(getattr(model, "act", None)) and callable(getattr(model, "evaluate", None)):
            return model
        raise ValueError(f"params.model.name: '{name}' returned a {type(model).__name__}, neither a subclass of "
                         f"one of rl_games' model classes (ModelA2C, ModelA2CContinuousLogStd, ...) nor an rlchain "
                         f"ActorCritic (docs/rl_games.md)")

    return build


def register_model(name: str, target_class: Any) -> None:
    """Make ``params.model.name: <name>`` use ``target_class(network)`` (replacing any earlier one)."""
    MODEL_REGISTRY[name] = lambda network, **kwargs: target_class(network)
    _model_builder.register_model(name, model_factory(name, target_class), overwrite=True)


class NetworkBuilder:
    """Network builders by name: ``load(params.network)`` returns the named builder, loaded."""

    def __init__(self) -> None:
        self.network_factory = ObjectFactory()
        self.network_factory.set_builders(NETWORK_REGISTRY)
        self.network_factory.register_builder("actor_critic", lambda **kwargs: network_builder.A2CBuilder())
        self.network_factory.register_builder("soft_actor_critic", lambda **kwargs: network_builder.SACBuilder())

    def load(self, params: dict) -> Any:
        network = self.network_factory.create(params["name"])
        network.load(params)
        return network


class ModelBuilder:
    """Model classes by name: ``load(params)`` returns ``params.model.name``'s model around ``params.network``."""

    def __init__(self) -> None:
        self.model_factory = ObjectFactory()
        self.model_factory.set_builders(MODEL_REGISTRY)
        presets = {"discrete_a2c": models.ModelA2C, "multi_discrete_a2c": models.ModelA2CMultiDiscrete,
                   "continuous_a2c": models.ModelA2CContinuous, "continuous_a2c_logstd":
                   models.ModelA2CContinuousLogStd, "central_value": models.ModelCentralValue,
                   "soft_actor_critic": models.ModelSACContinuous}
        for model_name, cls in presets.items():
            self.model_factory.register_builder(model_name, lambda network, cls=cls, **kwargs: cls(network))
        self.network_builder = NetworkBuilder()

    def get_network_builder(self) -> NetworkBuilder:
        return self.network_builder

    def load(self, params: dict) -> Any:
        network = self.network_builder.load(params["network"])
        return self.model_factory.create(params["model"]["name"], network=network)


__all__ = ["register_network", "register_model", "NetworkBuilder", "ModelBuilder", "NETWORK_REGISTRY",
           "MODEL_REGISTRY"]
