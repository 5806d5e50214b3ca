"""``params.config.obs_groups``: which part of the observation each network sees (teacher, student, critic).

One observation comes out of the env (a flat vector; a Dict is flattened key by key and remembers its keys,
an rl_games ``{'obs', 'state'}`` env becomes ``[obs | state]``). A group names the parts one network reads:

- a key of a Dict observation (``joint_pos``), or ``obs`` / ``state`` of a central-value env;
- an index (``3``) or a slice ``"start:stop"`` (``"0:2"``, ``"17:"``) of the flat vector.

The groups are resolved against the env's space by :mod:`rlchain.envs.obs_groups`; this module only
checks their form (no torch, no env).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rlchain.config.fields import non_negative, option

GROUPS = ("teacher", "student", "critic")


def check_parts(value: Any) -> str | None:
    """None for a valid group (None = the whole observation, or a non-empty list of keys, indices and
    ``"start:stop"`` slices), else what is wrong."""
    if value is None:
        return None
    if not isinstance(value, list) or not value:
        return f"expected a non-empty list of Dict keys, indices or 'start:stop' slices, got {value!r}"
    for i, part in enumerate(value):
        if isinstance(part, bool) or not isinstance(part, (int, str)):
            return f"[{i}]: expected a Dict key, an index or a 'start:stop' slice, got {part!r}"
    return None


def check_rate(value: float) -> str | None:
    """A probability in [0, 1)."""
    return None if 0.0 <= value < 1.0 else "must be in [0, 1)"


@dataclass(frozen=True)
class ObsGroupsConfig:
    """``config.obs_groups`` (rlchain): the part of the observation each network sees. A group left out
    (or None) sees the whole observation (``critic``: the env's ``state`` with a central-value env).
    Parts: Dict keys (``obs`` / ``state`` of an rl_games central-value env), indices or "start:stop"
    slices of the flat observation. See docs/distillation.md."""

    teacher: Any = option(None, "the teacher's view (distill) and PPO's when policy is teacher; on Dict "
                                "observations kept per key (a multi_input student) the keys the teacher reads, "
                                "a flat teacher getting them concatenated in this order", check=check_parts)
    student: Any = option(None, "the student's view (distill; PPO's when policy is student)", check=check_parts)
    critic: Any = option(None, "what central_value_config's critic sees (default: the env's state)",
                         check=check_parts)
    policy: str = option("teacher", "PPO: the group its actor-critic sees: teacher (stage one) or student "
                                    "(stage three, fine-tuning a distilled student)",
                         choices=("teacher", "student"))
    student_noise_std: float = option(0.0, "distill: Gaussian noise (this std) added to the student's view "
                                           "while training (a sensor's noise); not at play or export",
                                      check=non_negative)
    student_delay: int = option(0, "distill: the student sees the observation of this many steps ago while "
                                   "training (a slow sensor; an episode's first observation fills the line)",
                                check=non_negative)
    student_dropout: float = option(0.0, "distill: probability that each element of the student's view is "
                                         "zeroed while training (a dropped sensor reading)", check=check_rate)
