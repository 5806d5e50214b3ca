"""Torch modules built from the ``params.network`` block."""

from rlchain.networks.base import NetworkBuilder

__all__ = ["NetworkBuilder"]
