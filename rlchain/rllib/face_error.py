"""The face's error types, in a module of their own so any face module can raise it without importing the alias."""


class FaceImportError(ImportError):
    """A ``ray.rllib`` name rlchain's face does not offer (one line, with what to use instead)."""


class FaceNotOffered(NotImplementedError):
    """An RLlib call the face does not offer (one line, with what to use instead)."""
