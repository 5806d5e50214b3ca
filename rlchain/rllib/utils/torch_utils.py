"""``ray.rllib.utils.torch_utils``: the float bounds RLlib's action-masking modules add to logits."""

FLOAT_MIN = -3.4e38
FLOAT_MAX = 3.4e38

__all__ = ["FLOAT_MAX", "FLOAT_MIN"]
