"""Run-time errors shared across layers (config errors live in rlchain.config.errors)."""


class DivergenceError(RuntimeError):
    """A NaN or inf in a loss, the gradients, the parameters or the env's data."""


class EnvError(RuntimeError):
    """The environment raised, or returned data that does not fit its declared space."""


class NetworkError(RuntimeError):
    """A network broke its contract at run time, e.g. ``get_aux_loss()`` returned a non-scalar loss."""


class DistributedError(RuntimeError):
    """Under torchrun, a collective failed: another rank died, was killed or hung (multi_gpu)."""


def first_non_finite(named: dict[str, float]) -> str | None:
    """The first ``name = value`` whose value is NaN or inf, else None."""
    for name, value in named.items():
        if value != value or value in (float("inf"), float("-inf")):
            return f"{name} = {value}"
    return None
