"""``params.config`` of GRPO (algo ``grpo``): PPO's keys (the rollout, minibatches, clipping, Adam) and the
group-relative ones, as EmbodiChain defines them, plus rlchain's ``shared_starts``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from rlchain.config.fields import non_negative, option, positive
from rlchain.config.ppo import PPOConfig


def _group(value: int) -> str | None:
    return None if value >= 2 else "must be >= 2 (the advantage is normalised within each group)"


@dataclass(frozen=True)
class GRPOConfig(PPOConfig):
    """``params.config`` of ``algo: grpo``: no critic; per-step discounted returns normalised within groups."""

    group_size: int = option(4, "GRPO: envs per group, contiguous (envs 0..G-1 are group 0); num_actors must "
                                "divide by it", check=_group)
    kl_coef: float = option(0.02, "GRPO: weight of the k3 KL estimate to a frozen copy of the initial policy "
                                  "(0: no reference policy)", check=non_negative)
    eps: float = option(1e-8, "GRPO: added to the group's standard deviation", check=positive)
    reset_every_rollout: bool = option(True, "GRPO: reset every env at the start of each rollout (each rollout is "
                                             "a fresh set of episodes, as EmbodiChain does)")
    truncate_at_first_done: bool = option(True, "GRPO: only the steps up to each env's first episode end in the "
                                                "rollout count (masked afterwards)")
    shared_starts: bool = option(False, "GRPO (rlchain): every member of a group starts its rollout from the "
                                        "group's first env's initial state, so the group mean is a baseline for "
                                        "one start (needs reset_every_rollout and an env whose get_state() holds "
                                        "its batch as tensors: rlchain's tensor envs and contract envs on them)")

    value_bootstrap: bool = option(False, "GRPO: no critic, so no bootstrap (True only spends a value pass at "
                                          "time-outs)")

    other_algo_keys: ClassVar[dict[str, str]] = {}
    doc_note: ClassVar[str] = ("group-relative policy optimisation without a critic, docs/algorithms.md; PPO's keys "
                               "have the same meaning, the value keys are unused")

    def validate(self) -> tuple[str, str] | None:
        """The groups split the envs; shared starts come at a reset."""
        if self.num_actors % self.group_size:
            return "group_size", f"{self.group_size} does not divide num_actors {self.num_actors}"
        if self.shared_starts and not self.reset_every_rollout:
            return "shared_starts", "needs reset_every_rollout: True (the groups start together at each reset)"
        return None
