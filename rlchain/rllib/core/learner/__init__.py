"""``ray.rllib.core.learner``: only ``utils`` (the target-network helpers RLlib's example RLModules import).
RLlib's Learner classes are a one-line ImportError: the face does not run Learner subclasses (rlchain's PPO loss
options are config keys). Any other name is an AttributeError, as on any module (pickle's module search)."""

from typing import Any

from rlchain.rllib.face_error import FaceImportError

NOT_OFFERED = frozenset({"Learner", "TorchLearner", "LearnerGroup"})
"""RLlib's Learner classes (its ``core.learner`` exports)."""


def __getattr__(name: str) -> Any:
    if name not in NOT_OFFERED:
        raise AttributeError(f"module 'ray.rllib.core.learner' has no attribute '{name}'")
    raise FaceImportError(f"ray.rllib.core.learner.{name} is not offered by rlchain's RLlib face: RLlib's Learner "
                          f"subclasses are not run: rlchain's PPO loss options are config keys",
                          name="ray.rllib.core.learner")
