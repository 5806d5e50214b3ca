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

from rlchain.registry import ALGOS, ENVS, MODELS, NETWORKS, VECENVS


def register_network(name: str, builder: Any, overwrite: bool = False) -> Any:
    """Make ``params.network.name: <name>`` build with ``builder``."""
    return NETWORKS.register(name, builder, overwrite=overwrite)


def register_model(name: str, factory: Any, overwrite: bool = False) -> Any:
    """Make ``params.model.name: <name>`` use ``factory``."""
    return MODELS.register(name, factory, overwrite=overwrite)


def register_algo(name: str, trainer_cls: Any, overwrite: bool = False) -> Any:
    """Make ``params.algo.name: <name>`` train with ``trainer_cls``."""
    return ALGOS.register(name, trainer_cls, overwrite=overwrite)


__all__ = ["register_network", "register_model", "register_algo", "NETWORKS", "MODELS", "ALGOS",
           "ENVS", "VECENVS"]
