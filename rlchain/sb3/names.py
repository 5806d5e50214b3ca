"""rlchain's parameter names <-> Stable-Baselines3's, for MlpPolicy (pure functions on state dicts).

SB3 names the layers of an ``nn.Sequential`` of (Linear, activation) pairs by position (``0``, ``2``, ``4``, ...);
rlchain's MLP blocks are (Linear, activation) sub-sequentials (``net.0.0``, ``net.1.0``, ...). The tables:

======================================  ==============================================================
rlchain                                 Stable-Baselines3
======================================  ==============================================================
PPO ``network.policy.X`` (sb3_policy)     ``X`` (a user's ActorCriticPolicy: its own names)
PPO ``network.actor_trunk.mlp.net.i.0``  ``mlp_extractor.policy_net.2i``
PPO ``network.critic_trunk.mlp.net.i.0`` ``mlp_extractor.value_net.2i``
PPO ``network.logits`` / ``network.mu``  ``action_net``
PPO ``network.value`` / ``network.sigma`` ``value_net`` / ``log_std``
SAC ``network.actor.trunk.net.i.0``     ``actor.latent_pi.2i``
SAC ``network.actor.head`` (mu; log_std) ``actor.mu`` and ``actor.log_std`` (the head's two halves)
SAC ``network.critic.qK.0.net.i.0``     ``critic.qf(K-1).2i``; ``network.critic.qK.1``: its last layer
SAC ``critic_target.qK...``             ``critic_target.qf(K-1)...``
DQN ``network.trunk.net.i.0``           ``q_net.q_net.2i``; ``network.advantage``: its last layer
DQN ``target...``                       ``q_net_target...``
======================================  ==============================================================

Names outside these tables (input normalizers, SAC's ``log_alpha``, a dueling head's ``value``) keep rlchain's name.
"""

from __future__ import annotations

import re
from typing import Any

import torch

_PPO = [(r"network\.policy\.(.+)", "{w}"),  # the sb3_policy network: an ActorCriticPolicy's own names
        (r"network\.actor_trunk\.mlp\.net\.(\d+)\.0\.(\w+)", "mlp_extractor.policy_net.{2i}.{w}"),
        (r"network\.critic_trunk\.mlp\.net\.(\d+)\.0\.(\w+)", "mlp_extractor.value_net.{2i}.{w}"),
        (r"network\.(?:logits|mu)\.(\w+)", "action_net.{w}"), (r"network\.value\.(\w+)", "value_net.{w}"),
        (r"network\.sigma", "log_std")]


def _hidden(pattern: str, names: list[str]) -> int:
    """How many hidden layers the names matching ``pattern`` (index in group 1) have."""
    found = [int(m.group(1)) for n in names if (m := re.fullmatch(pattern, n))]
    return max(found) + 1 if found else 0


def _rename(rules: list[tuple[str, str]], name: str, last: int) -> str | None:
    for pattern, template in rules:
        m = re.fullmatch(pattern, name)
        if m is None:
            continue
        groups = m.groups()
        w = groups[-1] if groups and not groups[-1].isdigit() else ""
        i = int(groups[0]) if groups and groups[0].isdigit() else 0
        k = int(groups[0]) - 1 if "{k}" in template else 0
        if "{k}" in template:  # the groups are (K, i, w) or (K, w)
            i = int(groups[1]) if len(groups) == 3 else 0
        return template.format(**{"2i": 2 * i, "w": w, "k": k, "last": 2 * last})
    return None


def _rules(algo: str, names: list[str]) -> tuple[list[tuple[str, str]], int]:
    """The renaming rules of ``algo`` and the index of the last layer's hidden count (from rlchain's ``names``)."""
    if algo == "ppo":
        return _PPO, 0
    if algo == "sac":
        last = _hidden(r"network\.critic\.q1\.0\.net\.(\d+)\.0\.weight", names)
        return [(r"network\.actor\.trunk\.net\.(\d+)\.0\.(\w+)", "actor.latent_pi.{2i}.{w}"),
                (r"network\.critic\.q(\d+)\.0\.net\.(\d+)\.0\.(\w+)", "critic.qf{k}.{2i}.{w}"),
                (r"network\.critic\.q(\d+)\.1\.(\w+)", "critic.qf{k}.{last}.{w}"),
                (r"critic_target\.q(\d+)\.0\.net\.(\d+)\.0\.(\w+)", "critic_target.qf{k}.{2i}.{w}"),
                (r"critic_target\.q(\d+)\.1\.(\w+)", "critic_target.qf{k}.{last}.{w}")], last
    last = _hidden(r"network\.trunk\.net\.(\d+)\.0\.weight", names)
    return [(r"network\.trunk\.net\.(\d+)\.0\.(\w+)", "q_net.q_net.{2i}.{w}"),
            (r"network\.advantage\.(\w+)", "q_net.q_net.{last}.{w}"),
            (r"target\.trunk\.net\.(\d+)\.0\.(\w+)", "q_net_target.q_net.{2i}.{w}"),
            (r"target\.advantage\.(\w+)", "q_net_target.q_net.{last}.{w}")], last


def to_sb3(algo: str, state: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """rlchain's ``state`` of an ``algo`` (ppo, sac, dqn) MlpPolicy under SB3's names (same tensors)."""
    rules, last = _rules(algo, list(state))
    out = {}
    for name, value in state.items():
        if algo == "sac" and (m := re.fullmatch(r"network\.actor\.head\.(\w+)", name)):
            mu, log_std = value.chunk(2, dim=0)  # the head's rows: mu, then log_std
            out[f"actor.mu.{m.group(1)}"], out[f"actor.log_std.{m.group(1)}"] = mu, log_std
            continue
        out[_rename(rules, name, last) or name] = value
    return out


def from_sb3(algo: str, state: dict[str, Any], reference: dict[str, torch.Tensor]) -> dict[str, Any]:
    """SB3-named ``state`` under rlchain's names; ``reference`` is the rlchain model's own state dict (the
    inverse of :func:`to_sb3` is read off its names). Names neither knows are kept as they are."""
    rules, last = _rules(algo, list(reference))
    rlchain_name = {_rename(rules, name, last) or name: name for name in reference}
    out: dict[str, Any] = {}
    for name, value in state.items():
        if algo == "sac" and (m := re.fullmatch(r"actor\.(mu|log_std)\.(\w+)", name)):
            if m.group(1) == "mu":
                out[f"network.actor.head.{m.group(2)}"] = torch.cat([value, state[f"actor.log_std.{m.group(2)}"]])
            continue
        out[rlchain_name.get(name, name)] = value
    return out


def is_sb3_named(algo: str, state: dict[str, Any]) -> bool:
    """Whether ``state`` uses SB3's names (any of its MlpPolicy's top-level modules)."""
    roots = {"ppo": ("mlp_extractor.", "action_net.", "value_net.", "log_std"),
             "sac": ("actor.latent_pi.", "actor.mu.", "critic.qf"), "dqn": ("q_net.",)}[algo]
    return any(name.startswith(roots) for name in state)
