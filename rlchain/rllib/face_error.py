"""The face's one error type, in a module of its own so any face module can raise it without importing the alias."""


class FaceImportError(ImportError):
    """A ``ray.rllib`` name rlchain's face does not offer (one line, with what to use instead)."""
