"""``ray.rllib.utils.spaces``: the space helpers RLlib's example envs import."""
