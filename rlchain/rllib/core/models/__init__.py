"""``ray.rllib.core.models``: the names RLlib's encoders key their outputs with."""
