"""``ray.rllib.algorithms.impala.impala``, the module RLlib defines ``IMPALA`` and ``IMPALAConfig`` in (scripts
import either path): the face's, from :mod:`rlchain.rllib.algorithms.impala`."""

from rlchain.rllib.algorithms.impala import IMPALA, IMPALAConfig

__all__ = ["IMPALA", "IMPALAConfig"]
