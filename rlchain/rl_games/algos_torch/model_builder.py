"""rl_games' ``model_builder.register_network`` / ``register_model``, filling rlchain's registries.

A network builder (rl_games' ``NetworkBuilder`` shape: ``load(params)`` then ``build(name, **kwargs)``,
returning a module whose ``forward(input_dict)`` returns rl_games' output tuple) works as in rl_games.
A model is rlchain's: ``factory(network=..., action_space=..., obs_shape=..., value_size=..., config=...,
model_name=...)`` returning an :class:`rlchain.models.actor_critic.ActorCritic`; an rl_games model class
(a ``BaseModel`` with ``build``) is a one-line error naming it when the config uses it.
"""

from __future__ import annotations

from typing import Any

from rlchain import model_builder as _model_builder


def register_network(name: str, target_class: Any) -> None:
    """Make ``params.network.name: <name>`` build with ``target_class`` (replacing any earlier one)."""
    _model_builder.register_network(name, target_class, overwrite=True)


def register_model(name: str, target_class: Any) -> None:
    """Make ``params.model.name: <name>`` use ``target_class`` (rlchain's model factory contract)."""

    def factory(**kwargs: Any) -> Any:
        model = target_class(**kwargs)
        if not callable(getattr(model, "act", None)) or not callable(getattr(model, "evaluate", None)):
            raise ValueError(f"params.model.name: '{name}' returned a {type(model).__name__}, not an rlchain "
                             f"ActorCritic; rl_games model classes (BaseModel.build) are not supported: "
                             f"register an rlchain model factory (docs/rl_games.md)")
        return model

    _model_builder.register_model(name, factory, overwrite=True)


__all__ = ["register_network", "register_model"]
