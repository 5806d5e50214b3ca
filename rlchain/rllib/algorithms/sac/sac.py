"""``ray.rllib.algorithms.sac.sac``, the module RLlib defines ``SAC`` and ``SACConfig`` in (scripts import either
path): the face's, from :mod:`rlchain.rllib.algorithms.sac`."""

from rlchain.rllib.algorithms.sac import SAC, SACConfig

__all__ = ["SAC", "SACConfig"]
