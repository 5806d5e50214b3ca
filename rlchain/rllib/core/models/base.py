"""``ray.rllib.core.models.base``: encoder output keys (``ENCODER_OUT``, ``ACTOR``, ``CRITIC``)."""

ENCODER_OUT = "encoder_out"
ACTOR = "actor"
CRITIC = "critic"

__all__ = ["ACTOR", "CRITIC", "ENCODER_OUT"]
