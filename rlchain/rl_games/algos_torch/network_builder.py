"""rl_games' ``network_builder``: the base class of a user network builder (``load(params)``, then
``build(name, **kwargs)`` returning the torch module), rlchain's :class:`rlchain.networks.NetworkBuilder`."""

from __future__ import annotations

from rlchain.networks import NetworkBuilder

__all__ = ["NetworkBuilder"]
