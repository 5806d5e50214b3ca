"""RLlib's face of rlchain: RLlib's module paths, names and semantics over rlchain's one training loop.

``from rlchain.rllib.algorithms.ppo import PPOConfig`` for a one-line swap, or ``python -m rlchain.rllib
script.py`` to run an RLlib script unmodified (its ``ray.rllib`` imports resolve here; ``ray``, ``ray.tune`` and
``ray.init`` stay the real Ray). docs/rllib.md says what maps and what is not offered.
"""

from __future__ import annotations


def _register_all() -> None:
    """Register the face's algorithms as Ray Tune trainables under RLlib's names (``tune.Tuner("PPO", ...)``);
    Ray Tune calls this when it meets an algorithm name it does not know."""
    from rlchain.rllib.tune import register_trainables  # optional: ray[tune] (the module needs it)
    register_trainables()


__all__ = ["_register_all"]
