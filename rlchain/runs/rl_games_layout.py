"""rl_games' file names, checkpoint keys and TensorBoard extras, for runs started through rl_games' API
(``rlchain.rl_games``).

rl_games writes, in ``<train_dir>/<run>/nn``: the best checkpoint ``<name>.pth``; every ``save_frequency``
epochs (once games have finished) ``last_<name>_ep_<N>_rew_<R>.pth``; when the run stops
``last_<name>_ep_<N>_rew_<A>.pth`` with ``A`` the reward as numpy prints a one-element array, brackets
turned to underscores (``_81.18142_``, ``-inf`` before any game ended). Its epoch scalars sit at the frames
counted before the epoch, and it adds ``shaped_rewards/*``, ``performance/step_inference_fps`` and
``info/e_clip`` to the tags rlchain writes. Each checkpoint carries rl_games' keys beside rlchain's
(:func:`rl_games_keys`), so rl_games' own code reads it as written.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rlchain.registry import NETWORKS
from rlchain.runs import checkpoint as ckpt
from rlchain.runs import rl_games_checkpoint


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


def rl_games_keys(state: dict[str, Any]) -> dict[str, Any]:
    """``state`` with the keys rl_games writes beside rlchain's (under rl_games' API), so rl_games' own code reads
    the file without an export: ``model`` in rl_games' layout (rlchain's moves to ``rlchain_model``, where
    :func:`rlchain.runs.checkpoint.load` takes it back), ``optimizer``, ``frame``, ``last_mean_rewards``, and
    the rest of ``--export rl_games`` (SAC's networks and optimizers, the central value's). A network rl_games'
    layout cannot hold (one of your own, D2RL, ...) gets the counters only, and keeps rlchain's ``model``."""
    try:
        if not _rl_games_network(state):
            raise ValueError("a network rl_games does not build")
        theirs = rl_games_checkpoint.to_rl_games(state)
    except (ValueError, KeyError):
        theirs = {"frame": int(state["frames"])}
    theirs.setdefault("last_mean_rewards", state.get("best_reward"))
    out = dict(state)
    if "model" in theirs:
        out[ckpt.RLCHAIN_MODEL] = state["model"]
    theirs["env_state"] = state.get("env_state")  # the env's own state, as rlchain keeps it (None without one)
    for key, value in theirs.items():
        if key in ("model", "epoch") or key not in state:  # the others are rlchain's own
            out[key] = value
    return out


RL_GAMES_NETWORKS = ("actor_critic", "resnet_actor_critic", "soft_actor_critic")
"""rlchain's networks that rl_games builds too (the same modules under the same names)."""


def _rl_games_network(state: dict[str, Any]) -> bool:
    """Whether the checkpoint's network is one rl_games builds: rlchain's of :data:`RL_GAMES_NETWORKS`, or one
    registered through rl_games' ``register_network`` (its modules named as rl_games names them)."""
    params = (state.get("config") or {}).get("params") or {}
    name = (params.get("network") or {}).get("name", "actor_critic")
    return name in RL_GAMES_NETWORKS or (name in NETWORKS and getattr(NETWORKS.get(name), "rl_games_target", None)
                                         is not None)


__all__ = ["RlGamesTags", "final_stem", "periodic_stem", "rl_games_keys"]
