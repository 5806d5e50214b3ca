"""``ray.rllib.utils``."""
