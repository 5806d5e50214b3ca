"""A user package that adds its own algorithm: one module (reinforce.py: the algorithm and its config
class), this one registration line. The Loop holds the algorithm; it never subclasses the Loop."""

from rlchain import model_builder
from tests.smoke.user_algo.reinforce import Reinforce

model_builder.register_algo("reinforce", Reinforce, overwrite=True)
