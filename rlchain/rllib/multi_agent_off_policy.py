"""RLlib's DQN and SAC on a ``MultiAgentEnv``: rlchain's multi-policy DQN / SAC
(:mod:`rlchain.algos.multi_off_policy`), each policy its own off-policy agent, and RLlib's ``learners/<policy>``
results of each.

The config is the face's single-agent DQN / SAC translation (the config's algorithm class's ``translate``:
:func:`rlchain.rllib.translate.dqn_config`, :func:`rlchain.rllib.algorithms.sac.translate.sac_config`), its keys
shared by every policy, with a
``multi_agent`` block: every policy the top-level network and model for its agents' spaces, the agent -> policy
mapping, the trained policies. An iteration is the single-agent one's env steps (RLlib counts env steps).
"""

from __future__ import annotations

import glob
from typing import Any

import gymnasium as gym

from rlchain.config.errors import ConfigError
from rlchain.rllib.core import ALL_MODULES
from rlchain.rllib.off_policy_results import FRAMES, TargetUpdates, dqn_results, sac_results

OFF_POLICY = ("DQN", "SAC")
"""The face's algorithms a MultiAgentEnv trains off-policy."""


def off_policy_config(config: Any, env_name: str, run: dict[str, Any], spaces: dict[str, tuple],
                      mapping: dict[Any, list[str]], to_train: list[str] | None) -> dict[str, Any]:
    """The rlchain multi-policy DQN / SAC config: ``spaces`` is policy id -> (observation, action space) of its
    agents, ``mapping`` agent id -> its policy (one), ``to_train`` the trained policies (None: all)."""
    where = type(config).__name__
    listed = [agent for agent, pids in mapping.items() if len(pids) > 1]
    if listed:
        raise ConfigError(f"{where}.multi_agent()", "policy_mapping_fn", f"maps agent {listed[0]!r} to several "
                          f"policies across episodes: the face trains that with PPO only so far")
    kinds = {pid: type(act) for pid, (_, act) in spaces.items()}
    allowed = (gym.spaces.Discrete,) if config.algo_name == "DQN" else (gym.spaces.Box, gym.spaces.Discrete)
    for pid, kind in kinds.items():
        if kind not in allowed:
            raise ConfigError(where, "env", f"policy {pid!r}: {kind.__name__} actions are not mapped by the face "
                                            f"for {config.algo_name} ({' or '.join(a.__name__ for a in allowed)})")
    if len(set(kinds.values())) > 1:
        raise ConfigError(where, "env", "the policies' action spaces mix Box and Discrete: the face's multi-agent "
                                        "SAC takes one kind for every policy")
    obs_space = next(iter(spaces.values()))[0]  # the translations read no observation space (DQN, SAC)
    base = config.algo_class.translate(config, env_name, obs_space, gym.spaces.Box in kinds.values(), run)
    base["params"]["config"]["multi_agent"] = {
        "policies": {pid: {} for pid in spaces},
        "policy_mapping": {glob.escape(str(a)): pids[0] for a, pids in mapping.items()},
        "policies_to_train": None if to_train is None else [p for p in to_train if p in spaces]}
    return base


def off_policy_learners(algo: str, stats: dict[str, Any], cfg: dict[str, Any], policies: list[str],
                        targets: dict[str, TargetUpdates]) -> dict[str, dict[str, Any]]:
    """RLlib's ``learners/<policy>`` results of each trained policy from its ``<policy>.<name>`` epoch statistics
    (the single-agent DQN / SAC results, each policy's target-update counters its own; none for a policy not
    updated yet), and under ALL_MODULES
    the trained-steps counters summed over the policies."""
    results = dqn_results if algo == "DQN" else sac_results
    out: dict[str, dict[str, Any]] = {}
    every: dict[str, Any] = {}
    for pid in policies:
        own = {key[len(pid) + 1:]: value for key, value in stats.items() if key.startswith(f"{pid}.")}
        if not own.get("total_updates"):
            continue  # RLlib reports no learner before its first update (learning starts after warmup)
        own[FRAMES] = int(stats.get("frames", 0))  # the env steps so far (the target-update step's counter)
        learner = results(own, cfg, targets.setdefault(pid, TargetUpdates()))
        for key, value in learner.pop(ALL_MODULES, {}).items():
            every[key] = every.get(key, 0) + value
        out[pid] = learner
    out[ALL_MODULES] = every
    return out
