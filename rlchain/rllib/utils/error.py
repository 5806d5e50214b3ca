"""``ray.rllib.utils.error``: the exception types RLlib's example envs raise (a crashing env's ``EnvError``)."""


class UnsupportedSpaceException(Exception):
    """A space an algorithm or module does not take."""


class EnvError(Exception):
    """An env failed (RLlib's example envs raise it on purpose); the face's run ends with it as any env error."""


class MultiAgentEnvError(Exception):
    """A multi-agent env broke RLlib's dict-of-agents API."""


class NotSerializable(Exception):
    """An object that cannot be sent to another process."""


__all__ = ["EnvError", "MultiAgentEnvError", "NotSerializable", "UnsupportedSpaceException"]
