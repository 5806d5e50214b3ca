"""Public extension points with rl_games' names: register networks and models from user code.

    from rlchain import model_builder
    model_builder.register_network('testnet', TestNetBuilder)

A network builder follows :class:`rlchain.networks.NetworkBuilder` (``load(params)`` then
``build(name, **kwargs)``) or is a function ``builder(params, **kwargs) -> nn.Module``.
A model factory is called as ``factory(network=..., action_space=..., obs_shape=..., value_size=...,
config=..., model_name=...)`` and returns an :class:`rlchain.models.actor_critic.ActorCritic`.
"""

from __future__ import annotations

from typing import Any

from rlchain.registry import ALGOS, MODELS, NETWORK_CONFIGS, NETWORKS


def register_network(name: str, builder: Any, overwrite: bool = False, config_class: type | None = None) -> Any:
    """Make ``params.network.name: <name>`` build with ``builder``.

    ``config_class`` (a frozen dataclass whose fields are declared with ``rlchain.config.fields.option``)
    makes the network block parse into it, so an unknown key is a config error with a did-you-mean; the
    builder then gets the dataclass. Without it (and without a ``config_class`` attribute on a builder
    class) the block stays a dict and keys the builder never reads are a warning naming them.
    """
    NETWORKS.register(name, builder, overwrite=overwrite)
    if config_class is not None:
        NETWORK_CONFIGS[name] = config_class
    else:
        NETWORK_CONFIGS.pop(name, None)
    return builder


def register_model(name: str, factory: Any, overwrite: bool = False) -> Any:
    """Make ``params.model.name: <name>`` use ``factory``."""
    return MODELS.register(name, factory, overwrite=overwrite)


def register_algo(name: str, algorithm_cls: Any, overwrite: bool = False) -> Any:
    """Make ``params.algo.name: <name>`` train with ``algorithm_cls`` (a class following
    :class:`rlchain.algos.base.algorithm.Algorithm`, which the Loop holds)."""
    return ALGOS.register(name, algorithm_cls, overwrite=overwrite)


__all__ = ["register_network", "register_model", "register_algo", "NETWORKS", "MODELS", "ALGOS"]
