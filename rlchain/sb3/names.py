"""rlchain's parameter names <-> Stable-Baselines3's, for MlpPolicy (pure functions on state dicts).

SB3 names the layers of an ``nn.Sequential`` of (Linear, activation) pairs by position (``0``, ``2``, ``4``, ...), as
rlchain's MLPs (rl_games' layout) do: the positions carry over. The tables:

=========================================  ==============================================================
rlchain                                    Stable-Baselines3
=========================================  ==============================================================
PPO ``a2c_network.policy.X`` (sb3_policy)  ``X`` (a user's ActorCriticPolicy: its own names)
PPO ``a2c_network.actor_mlp.i``             ``mlp_extractor.policy_net.i``
PPO ``a2c_network.critic_mlp.i``            ``mlp_extractor.value_net.i``
PPO ``a2c_network.logits`` / ``.mu``        ``action_net``
PPO ``a2c_network.value`` / ``.sigma``      ``value_net`` / ``log_std``
SAC ``network.actor.trunk.i`` (hidden)      ``actor.latent_pi.i``
SAC ``network.actor.trunk`` last (mu; log_std) ``actor.mu`` and ``actor.log_std`` (the layer's two halves)
SAC ``network.critic.QK.i``                 ``critic.qf(K-1).i``
SAC ``critic_target.QK.i``                  ``critic_target.qf(K-1).i``
DQN ``network.trunk.i``                     ``q_net.q_net.i``; ``network.advantage``: its last layer
DQN ``target...``                           ``q_net_target...``
=========================================  ==============================================================

Names outside these tables (input normalizers, SAC's ``log_alpha``, a dueling head's ``value``) keep rlchain's name.
"""

from __future__ import annotations

import re
from typing import Any

import torch

_PPO = [(r"a2c_network\.policy\.(.+)", "{w}"),  # the sb3_policy network: an ActorCriticPolicy's own names
        (r"a2c_network\.actor_mlp\.(\d+)\.(\w+)", "mlp_extractor.policy_net.{i}.{w}"),
        (r"a2c_network\.critic_mlp\.(\d+)\.(\w+)", "mlp_extractor.value_net.{i}.{w}"),
        (r"a2c_network\.(?:logits|mu)\.(\w+)", "action_net.{w}"), (r"a2c_network\.value\.(\w+)", "value_net.{w}"),
        (r"a2c_network\.sigma", "log_std")]


def _last(pattern: str, names: list[str]) -> int:
    """The largest Sequential index (group 1) among the names matching ``pattern``."""
    return max((int(m.group(1)) for n in names if (m := re.fullmatch(pattern, n))), default=0)


def _rename(rules: list[tuple[str, str]], name: str, last: int) -> str | None:
    for pattern, template in rules:
        m = re.fullmatch(pattern, name)
        if m is None:
            continue
        groups = list(m.groups())
        k = int(groups.pop(0)) - 1 if "{k}" in template else 0  # the groups are (K, i, w)
        w = groups[-1] if groups and not groups[-1].isdigit() else ""
        i = int(groups[0]) if groups and groups[0].isdigit() else 0
        return template.format(i=i, w=w, k=k, last=last)
    return None


def _rules(algo: str, names: list[str]) -> tuple[list[tuple[str, str]], int]:
    """The renaming rules of ``algo`` and the index of its last layer (SAC's actor output, DQN's advantage)."""
    if algo == "ppo":
        return _PPO, 0
    if algo == "sac":
        return [(r"network\.critic\.Q(\d+)\.(\d+)\.(\w+)", "critic.qf{k}.{i}.{w}"),
                (r"critic_target\.Q(\d+)\.(\d+)\.(\w+)", "critic_target.qf{k}.{i}.{w}"),
                (r"network\.actor\.trunk\.(\d+)\.(\w+)", "actor.latent_pi.{i}.{w}")], \
            _last(r"network\.actor\.trunk\.(\d+)\.weight", names)
    last = _last(r"network\.trunk\.(\d+)\.weight", names) + 2 if any(n.startswith("network.trunk.") for n in names) \
        else 0
    return [(r"network\.trunk\.(\d+)\.(\w+)", "q_net.q_net.{i}.{w}"),
            (r"network\.advantage\.(\w+)", "q_net.q_net.{last}.{w}"),
            (r"target\.trunk\.(\d+)\.(\w+)", "q_net_target.q_net.{i}.{w}"),
            (r"target\.advantage\.(\w+)", "q_net_target.q_net.{last}.{w}")], last


def to_sb3(algo: str, state: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """rlchain's ``state`` of an ``algo`` (ppo, sac, dqn) MlpPolicy under SB3's names (same tensors)."""
    rules, last = _rules(algo, list(state))
    out = {}
    for name, value in state.items():
        if algo == "sac" and (m := re.fullmatch(rf"network\.actor\.trunk\.{last}\.(\w+)", name)):
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
                out[f"network.actor.trunk.{last}.{m.group(2)}"] = torch.cat([value,
                                                                            state[f"actor.log_std.{m.group(2)}"]])
            continue
        out[rlchain_name.get(name, name)] = value
    return out


def is_sb3_named(algo: str, state: dict[str, Any]) -> bool:
    """Whether ``state`` uses SB3's names (any of its MlpPolicy's top-level modules)."""
    roots = {"ppo": ("mlp_extractor.", "action_net.", "value_net.", "log_std"),
             "sac": ("actor.latent_pi.", "actor.mu.", "critic.qf"), "dqn": ("q_net.",)}[algo]
    return any(name.startswith(roots) for name in state)
