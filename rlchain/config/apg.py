"""``params.config`` of APG (algo ``apg``): analytic policy gradients through a differentiable tensor env."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from rlchain.config.fields import non_negative, option, positive
from rlchain.config.run import RunConfig


@dataclass(frozen=True)
class APGConfig(RunConfig):
    """``params.config`` of ``algo: apg``: the policy's return is differentiated through the env's steps."""

    doc_note: ClassVar[str] = "analytic policy gradients through a differentiable tensor env, docs/algorithms.md"

    horizon_length: int = option(16, "APG: env steps per segment (EmbodiChain's segment_length): one optimizer "
                                     "step per segment, the graph cut after it (truncated backpropagation)",
                                 check=positive)
    learning_rate: float = option(3e-4, "Adam learning rate", check=positive)
    lr_schedule: str | None = option(None, "None (constant) or linear (to min_lr over max_epochs / max_frames)",
                                     choices=("linear", "constant"))
    min_lr: float = option(0.0, "with lr_schedule linear: the final learning rate", check=non_negative)
    weight_decay: float = option(0.0, "Adam weight decay", check=non_negative)
    entropy_coef: float = option(0.0, "weight of the policy's discounted entropy in the objective")
    grad_norm: float = option(0.5, "max gradient norm", check=positive)
    truncate_grads: bool = option(True, "clip gradients to grad_norm")
    deterministic_actions: bool = option(False, "act with the mean (no exploration noise); else a "
                                                "reparameterised sample mu + sigma * noise")
    skip_nonfinite_updates: bool = option(True, "a segment whose loss or gradient is not finite is skipped "
                                                "(counted in info/skipped_update); False: the run stops")
    use_action_masks: bool = option(False, "APG: must stay False (continuous actions)")
    normalize_value: bool = option(False, "APG: must stay False (no critic)")

    def validate(self) -> tuple[str, str] | None:
        """APG differentiates through raw observations and continuous actions."""
        if self.normalize_input:
            return "normalize_input", "APG reads raw observations; set False"
        if self.use_action_masks or self.normalize_value:
            return "use_action_masks" if self.use_action_masks else "normalize_value", "must be False for APG"
        return None
