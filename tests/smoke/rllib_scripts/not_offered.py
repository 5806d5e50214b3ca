from ray.rllib.core.learner.learner import Learner  # noqa: F401
