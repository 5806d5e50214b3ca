"""``ray.rllib.algorithms.ppo.torch``: PPO's default torch RLModule (to subclass, as RLlib's examples do)."""
