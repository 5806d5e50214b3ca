"""``ray.rllib.env.env_runner_group``: ``EnvRunnerGroup`` (the face's, :mod:`rlchain.rllib.env_runner_group`)."""

from rlchain.rllib.env_runner_group import EnvRunnerGroup

__all__ = ["EnvRunnerGroup"]
