"""The off-policy stepper's old import path: it lives in :mod:`rlchain.algos.core.stepper`."""

from rlchain.algos.core.stepper import OffPolicyStepper as _OffPolicyStepper
from rlchain.deprecation import renamed

__getattr__ = renamed(__name__, {
    "OffPolicyStepper": ("rlchain.algos.core.stepper.OffPolicyStepper", _OffPolicyStepper),
})
