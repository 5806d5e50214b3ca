"""A user package that adds its own algorithm: one module, one config class, this one registration."""

from rlchain import model_builder
from tests.smoke.user_algo.reinforce import ReinforceTrainer

model_builder.register_algo("reinforce", ReinforceTrainer, overwrite=True)
