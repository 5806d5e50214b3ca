"""rl_games' file names and TensorBoard extras, for runs started through rl_games' API (``rlchain.rl_games``).

rl_games writes, in ``<train_dir>/<run>/nn``: the best checkpoint ``<name>.pth``; every ``save_frequency``
epochs (once games have finished) ``last_<name>_ep_<N>_rew_<R>.pth``; when the run stops
``last_<name>_ep_<N>_rew_<A>.pth`` with ``A`` the reward as numpy prints a one-element array, brackets
turned to underscores (``_81.18142_``, ``-inf`` before any game ended). Its epoch scalars sit at the frames
counted before the epoch, and it adds ``shaped_rewards/*``, ``performance/step_inference_fps`` and
``info/e_clip`` to the tags rlchain writes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def periodic_stem(name: str, epoch: int, reward: float) -> str:
    """The file stem of rl_games' every-``save_frequency`` checkpoint."""
    return f"last_{name}_ep_{epoch}_rew_{str(np.float32(reward))}"


def final_stem(name: str, epoch: int, reward: float | None) -> str:
    """The file stem of rl_games' checkpoint when the run stops (``reward`` None: no game ended)."""
    shown = str(np.array([reward], dtype=np.float32)).replace("[", "_").replace("]", "_") \
        if reward is not None else "-inf"
    return f"last_{name}_ep_{epoch}_rew_{shown}"


@dataclass(frozen=True)
class RlGamesTags:
    """What the extra tags need of the config: PPO's clip and the reward shaper's affine part (``shaped``
    is False when the shaper clips or takes a log, whose episode sums rlchain does not keep)."""

    e_clip: float | None
    scale_value: float
    shift_value: float
    shaped: bool

    def scalars(self, episodes: dict[str, float] | None, step_fps: float) -> dict[str, float]:
        """The tags rl_games writes beside rlchain's for one epoch."""
        out = {"performance/step_inference_fps": step_fps}
        if self.e_clip is not None:
            out["info/e_clip"] = self.e_clip
        if episodes is not None and self.shaped:  # sum_t scale * (r_t + shift) over an episode
            value = self.scale_value * (episodes["reward"] + self.shift_value * episodes["length"])
            out.update({"shaped_rewards/step": value, "shaped_rewards/iter": value, "shaped_rewards/time": value})
        return out


__all__ = ["RlGamesTags", "final_stem", "periodic_stem"]
