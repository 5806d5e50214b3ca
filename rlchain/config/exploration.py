"""rsl_rl's legged-robot extras as PPO config blocks: ``rnd`` (random network distillation, an intrinsic
reward) and ``symmetry`` (mirrored samples and a mirror loss). Their torch halves live in
rlchain/algos/core/rnd.py and rlchain/algos/core/symmetry.py; docs/robot_learning.md describes both."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rlchain.config.fields import non_negative, option, positive


def check_units(value: Any) -> str | None:
    """A list of layer sizes (ints >= 1), possibly empty."""
    if not isinstance(value, list) or any(isinstance(u, bool) or not isinstance(u, int) or u < 1 for u in value):
        return f"expected a list of layer sizes (integers >= 1), got {value!r}"
    return None


@dataclass(frozen=True)
class RndConfig:
    """``config.rnd`` (rlchain; rsl_rl's ``rnd_cfg``): random network distillation. A fixed random target
    network and a trained predictor embed the observation; the intrinsic reward ``weight * ||predictor(s) -
    target(s)||`` (on each step's next observation, as rsl_rl) is added to the env's reward in the rollout, and
    the predictor regresses the target on the rollout's observations after each PPO update. Novel states
    score high until the predictor has seen them."""

    weight: float = option(0.5, "scale of the intrinsic reward added to the (shaped) env reward", check=non_negative)
    learning_rate: float = option(1e-3, "the predictor's Adam learning rate", check=positive)
    num_outputs: int = option(16, "embedding size of the target and the predictor", check=positive)
    predictor_units: list[int] = option([64, 64], "the predictor MLP's hidden layer sizes (elu)", check=check_units)
    target_units: list[int] = option([64, 64], "the target MLP's hidden layer sizes (elu)", check=check_units)
    state_normalization: bool = option(True, "normalize the RND input with rsl_rl's empirical normalization "
                                             "(statistics from every rollout step)")
    mini_epochs: int = option(1, "predictor passes over the rollout per epoch (minibatches of minibatch_size)",
                              check=positive)
    obs: Any = option(None, "the part of the actor's observation the RND reads: a list of indices or "
                            "'start:stop' slices (default: all of it)")


@dataclass(frozen=True)
class SymmetryConfig:
    """``config.symmetry`` (rlchain; rsl_rl's ``symmetry_cfg``): a mirror map of the robot (``go1``, ``g1`` for
    mjlab's velocity tasks, or ``module:function`` returning a :class:`~rlchain.algos.core.symmetry.MirrorMap`
    for the env's observation and action sizes) gives each sample its left-right mirror image; the mirror loss
    (the mean squared difference between the policy's mean action on a mirrored observation and the mirrored
    mean action) is minimised over the rollout after each PPO update; ``data_augmentation`` also trains the PPO
    objective on the mirrored samples. Continuous actions, feed-forward policies."""

    mirror: str = option(doc="go1, g1, or module:function returning a MirrorMap (called with the actor's "
                             "observation size and the action size)")
    mirror_loss_coef: float = option(1.0, "weight of the mirror loss (0 = off)", check=non_negative)
    data_augmentation: bool = option(False, "train the PPO objective on the mirrored samples as well (rsl_rl's "
                                            "use_data_augmentation): the batch doubles, the minibatch size stays "
                                            "(rsl_rl doubles the minibatch instead)")
