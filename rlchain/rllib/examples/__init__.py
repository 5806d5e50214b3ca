"""``ray.rllib.examples``: the helpers RLlib's example scripts import (``examples.utils``)."""
