"""The ``params.config.multi_agent`` block: several policies, and which agent each one plays.

Parsed once here into a frozen :class:`PolicyPlan` per policy (its own network, model preset and
PPO keys), and a :class:`PolicyMapping` from agent ids to policy names (globs, first match wins). A glob may
name a list of policies: its agents play one of them per episode (:mod:`rlchain.models.seats` draws it), so
every policy of the list gets a slot for each such agent.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.fields import option
from rlchain.errors import did_you_mean

KEY = "params.config.multi_agent"

RUN_LEVEL_KEYS = ("env_name", "env_config", "env_runners", "vecenv_type", "num_actors", "env_groups",
                  "horizon_length", "max_epochs", "max_frames", "score_to_win", "name", "device", "train_dir",
                  "full_experiment_name", "player", "evaluation", "callbacks", "save_best_after",
                  "save_frequency", "save_frequency_frames", "checkpoint_names", "games_to_track", "print_stats",
                  "progress", "multi_gpu", "self_play_config",
                  "multi_agent", "central_value_config", "torch_compile", "compile_update", "cuda_graph", "divergence",
                  "seq_length", "bptt_length", "zero_rnn_on_done", "mixed_precision", "log_writers")
"""params.config keys that belong to the whole run (one rollout, one stop rule): a policy's
``config`` may not set them."""


@dataclass(frozen=True)
class PolicySpec:
    """``multi_agent.policies.<name>``: one policy. ``{}`` = the top-level network, model and keys."""

    network: Any = option(None, "this policy's network block, parsed like params.network (default: "
                                "params.network)")
    model: Any = option(None, "this policy's model preset, `{name: ...}` like params.model (default: "
                              "params.model)")
    config: dict = option({}, "PPO keys (learning_rate, entropy_coef, gamma, minibatch_size, "
                              "normalize_input, ...) overriding params.config for this policy; run-level "
                              "keys (num_actors, horizon_length, max_epochs, ...) stay at params.config")


@dataclass(frozen=True)
class MultiAgentConfig:
    """``config.multi_agent``: PettingZoo agents played by several policies (env_name: pettingzoo).

    Each policy has its own model, optimizer, normalizers, rollout storage and adaptive lr, and
    logs under ``rewards/<policy>/...`` and ``losses/<policy>/...``. See docs/multi_agent.md.
    """

    policies: dict = option({}, "policy name -> its block (see multi_agent.policies.<name>); `{}` is the "
                                "top-level network and keys. Empty: one policy, `shared`, for every agent")
    policy_mapping: dict = option({}, "agent id glob -> policy name, e.g. {'adversary_*': predator, "
                                      "'agent_*': prey}, or a list of policy names: one of them, drawn "
                                      "uniformly at random at each episode start of each env (the env's own "
                                      "choice where it names one), e.g. {player_1: [always_same, beat_last]}; "
                                      "the first matching glob wins; an agent that matches none is an error. "
                                      "Empty with one policy: every agent plays it")
    policies_to_train: list[str] | None = option(None, "policies that learn (default: all); the others act "
                                                       "frozen (their weights come from the checkpoint or "
                                                       "a snapshot)")
    snapshots: dict = option({}, "self-play: frozen policy -> the trained policy it is a snapshot of, "
                                 "e.g. {opponent: learner}; refreshed on the self_play_config rule (the trained "
                                 "policy's game scores), env_update_num envs at a time")


class PolicyMapping:
    """Agent id -> the policies that may play it, by globs in order, first match wins (``policy_mapping``): one
    policy, or a list of them of which each episode plays one."""

    def __init__(self, rules: dict[str, str | list[str]], policies: list[str], source: str = "") -> None:
        self.rules = [(pattern, [value] if isinstance(value, str) else list(value)) for pattern, value in rules.items()]
        self.policies = policies
        self.source = source

    def candidates(self, agent: str) -> list[str]:
        """The policies that may play ``agent`` (one: it plays it for the run); a one-line ConfigError when no glob
        matches it."""
        if not self.rules and len(self.policies) == 1:
            return [self.policies[0]]
        for pattern, names in self.rules:
            if fnmatch.fnmatchcase(agent, pattern):
                return names
        globs = ", ".join(repr(p) for p, _ in self.rules) or "none"
        raise ConfigError(self.source, f"{KEY}.policy_mapping", f"agent '{agent}' matches no glob "
                                                                 f"(globs: {globs}); add one for it")

    def assign(self, agents: list[str]) -> dict[str, list[str]]:
        """policy name -> the agents it may play (its slots), in the env's agent order (every policy listed)."""
        out: dict[str, list[str]] = {name: [] for name in self.policies}
        for agent in agents:
            for name in self.candidates(agent):
                out[name].append(agent)
        return out


def check_multi_agent(ma: MultiAgentConfig, source: str) -> list[str]:
    """Cross-key checks of the block; returns the policy names (``['shared']`` when none are given)."""
    names = list(ma.policies) or ["shared"]
    for glob, value in ma.policy_mapping.items():
        where = f"{KEY}.policy_mapping.{glob}"
        if isinstance(value, str):
            value = [value]
        elif not (isinstance(value, (list, tuple)) and value and all(isinstance(v, str) for v in value)):
            raise ConfigError(source, where, f"expected a policy name or a non-empty list of policy names, got "
                                             f"{value!r}")
        elif len(set(value)) != len(value):
            raise ConfigError(source, where, f"names a policy twice ({', '.join(value)})")
        for policy in value:
            if policy not in names:
                raise ConfigError(source, where, _unknown(policy, names))
    for i, policy in enumerate(ma.policies_to_train or []):
        if policy not in names:
            raise ConfigError(source, f"{KEY}.policies_to_train[{i}]", _unknown(policy, names))
    train = set(ma.policies_to_train if ma.policies_to_train is not None else names)
    for frozen, trained in ma.snapshots.items():
        if frozen not in names:
            raise ConfigError(source, f"{KEY}.snapshots", _unknown(frozen, names))
        if trained not in names:
            raise ConfigError(source, f"{KEY}.snapshots.{frozen}", _unknown(trained, names))
        if frozen in train or trained not in train:
            raise ConfigError(source, f"{KEY}.snapshots.{frozen}", f"the snapshot '{frozen}' must be frozen (left "
                              f"out of policies_to_train) and '{trained}' trained")
    if len(names) > 1 and not ma.policy_mapping:
        raise ConfigError(source, f"{KEY}.policy_mapping", f"required with several policies ({', '.join(names)}): "
                                                           f"agent id glob -> policy name")
    return names


def _unknown(name: str, names: list[str]) -> str:
    hint = did_you_mean(name, names, n=1)
    return f"unknown policy '{name}' (policies: {', '.join(names)}){hint}"
