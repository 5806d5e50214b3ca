"""``ray.rllib.algorithms.appo.appo``, the module RLlib defines ``APPO`` and ``APPOConfig`` in (scripts import either
path): the face's, from :mod:`rlchain.rllib.algorithms.appo`."""

from rlchain.rllib.algorithms.appo import APPO, APPOConfig

__all__ = ["APPO", "APPOConfig"]
