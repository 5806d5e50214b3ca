"""Action repeat for batched envs that can step a subset of their envs (envpool's ``env_id``).

``env_config.action_repeat: k`` on an envpool task: every action the policy picks is applied for
``k`` env steps (MuJoCo Playground trains its manipulation tasks with 4: at the env's 5 ms control
step a policy acting every step has a 4x longer credit-assignment horizon to bridge). The rewards
of the ``k`` steps are summed; an env whose episode ends at step ``j < k`` stops there (it is not
stepped into its next episode with the old action), and what the policy sees is the observation
after the last step taken.

Infos: the value of the last step taken, except success flags (``success``, ``is_success``), which
count when any of the steps set them (a MuJoCo Playground push-cube success lasts one step, then
the target moves), and Atari's unclipped ``reward``, which is summed like the reward.

Frames count decisions (one per repeated action), as rl_games counts agent steps; the env's own
``max_episode_steps`` counts its steps, so an episode holds at most ``max_episode_steps / k``
decisions.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

ANY_KEYS = frozenset({"success", "is_success"})
"""Info keys that hold when any repeated step set them."""
SUM_KEYS = frozenset({"reward"})
"""Info keys summed over the repeated steps (Atari's unclipped reward)."""

RawStep = tuple[Any, Any, Any, Any, dict]
"""(obs, reward, terminated, truncated, infos) as envpool returns them; ``infos['env_id']`` names the rows."""


def _writable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: np.array(v) for k, v in value.items()}
    return np.array(value)


def _put(target: Any, rows: np.ndarray, value: Any) -> None:
    """``target[rows] = value`` for an array or a dict of arrays (Dict observations)."""
    if isinstance(target, dict):
        for key in target:
            target[key][rows] = value[key]
    else:
        target[rows] = value


def repeat_step(step_subset: Callable[[np.ndarray, np.ndarray], RawStep], actions: np.ndarray,
                first: RawStep, repeat: int) -> RawStep:
    """Steps 2..``repeat`` of an action repeat whose first step (all envs) returned ``first``.

    ``step_subset(actions[ids], ids)`` steps the envs ``ids`` (int32, rows of ``actions``) once and
    returns their raw results with ``infos['env_id']`` naming the row of each. Envs whose episode
    ended stop; the others step again with their action. Returns the merged raw step for all envs.
    """
    obs, reward, terminated, truncated, infos = first
    obs = _writable(obs)
    reward = np.array(reward, dtype=np.float64)
    terminated, truncated = np.array(terminated, dtype=bool), np.array(truncated, dtype=bool)
    n = reward.shape[0]
    infos = {k: (np.array(v) if isinstance(v, np.ndarray) and v.shape[:1] == (n,) else v) for k, v in infos.items()}
    for _ in range(repeat - 1):
        running = ~(terminated | truncated)
        if not running.any():
            break
        ids = np.flatnonzero(running).astype(np.int32)
        sub_obs, sub_reward, sub_term, sub_trunc, sub_infos = step_subset(actions[ids], ids)
        rows = np.asarray(sub_infos["env_id"]).astype(np.int64)
        _put(obs, rows, sub_obs)
        reward[rows] += np.asarray(sub_reward, dtype=np.float64)
        terminated[rows] = np.asarray(sub_term, dtype=bool)
        truncated[rows] = np.asarray(sub_trunc, dtype=bool)
        for key, value in sub_infos.items():
            mine = infos.get(key)
            if key == "env_id" or not isinstance(mine, np.ndarray) or mine.shape[:1] != (n,):
                continue
            value = np.asarray(value)
            if key in ANY_KEYS:
                mine[rows] = np.maximum(mine[rows], value)
            elif key in SUM_KEYS:
                mine[rows] = mine[rows] + value
            else:
                mine[rows] = value
    return obs, reward.astype(np.float32), terminated, truncated, infos
