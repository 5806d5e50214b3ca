"""rl_games SAC checkpoints in and out: pure conversions between rl_games' SAC ``.pth`` dict and rlchain's.

rl_games (1.6.5 and 2.0) saves its SAC as ``{'actor', 'critic', 'critic_target', 'running_mean_std', 'epoch',
'frame', 'actor_optimizer', 'critic_optimizer', 'log_alpha_optimizer'}``, 2.0 adds ``log_alpha`` and
``last_mean_rewards`` (1.6.5 keeps no temperature: its resume starts from ``init_alpha``, and so does rlchain's
from such a file). Each network is a state dict of one Sequential per MLP: the actor ``trunk.<2 * layer>``
(linear, activation, ...) ending in the ``2 * actions`` output layer, the twin critics ``Q1`` / ``Q2`` likewise
ending in one output. rlchain's :class:`~rlchain.algos.off_policy.sac_agent.SoftActorCritic` holds the same function:
``network.actor.trunk.mlp`` layers ``net.<layer>.0`` and ``head``, ``network.critic.q1.0.net.<layer>.0`` and
``q1.1``, ``critic_target`` the same, ``log_alpha``, ``obs_norm``. Each optimizer holds its network's
parameters in the same order in both, so its state carries over by position.

rl_games 2.0's ``network.normalization`` adds a norm after each hidden activation: rlchain's
``mlp.norm_after_activation`` blocks (see :mod:`rlchain.runs.rl_games_mlp`). Other layouts are a ValueError
naming the first key that has no counterpart.
"""

from __future__ import annotations

import re
from typing import Any

from rlchain.runs import rl_games_mlp

COMPILED_PREFIX = "_orig_mod."
NETWORKS = ("actor", "critic", "critic_target")
OPTIMIZERS = {"actor_optimizer": "actor_opt", "critic_optimizer": "critic_opt", "log_alpha_optimizer": "alpha_opt"}
_NORM_STATS = {"running_mean": "mean", "running_var": "var", "count": "count"}
_OURS = {"actor": "network.actor", "critic": "network.critic", "critic_target": "critic_target"}
_MLPS = {"actor": ("trunk",), "critic": ("Q1", "Q2"), "critic_target": ("Q1", "Q2")}
# rl_games' Sequential -> (its name, rlchain's hidden-layer prefix, rlchain's output-layer prefix) per network
_CRITIC_MLPS = (("Q1", "q1.0.net.", "q1.1."), ("Q2", "q2.0.net.", "q2.1."))
_RLCHAIN_MLPS = {"actor": (("trunk", "trunk.net.", "head."),), "critic": _CRITIC_MLPS, "critic_target": _CRITIC_MLPS}


def is_sac(state: Any) -> bool:
    """Whether ``state`` is an rl_games SAC checkpoint (1.6.5 or 2.0)."""
    return isinstance(state, dict) and all(isinstance(state.get(k), dict) for k in NETWORKS)


def is_rlchain_sac(model: dict[str, Any]) -> bool:
    """Whether ``model`` (an rlchain model state dict) is a SoftActorCritic's."""
    return "network.actor.head.weight" in model and "network.critic.q1.1.weight" in model


def best_reward(state: dict[str, Any]) -> float:
    """rlchain's ``best_reward`` as rl_games' ``last_mean_rewards`` (its own start value when none is finite)."""
    best = state.get("best_reward")
    return float(best) if best is not None and best == best and abs(best) != float("inf") else -1000000000.0


def _strip(names: dict[str, Any]) -> dict[str, Any]:
    return {key.replace(COMPILED_PREFIX, ""): value for key, value in names.items()}


def _mlp_names(part: str, seq: str, keys: list[str], tensors: dict[str, Any]) -> dict[str, str]:
    """rl_games' Sequential ``<seq>.<i>.<p>`` of network ``part`` (hidden blocks linear, activation[, norm], then
    the output linear layer) -> rlchain names."""
    where = rl_games_mlp.sequential_layers({k: tensors[k] for k in keys}, seq, f"{part}.")
    last = max((layer for layer, _ in where.values()), default=-1)
    ours = _OURS[part]
    out: dict[str, str] = {}
    for key in keys:
        index, param = key[len(seq) + 1:].split(".", 1)
        layer, position = where[int(index)]
        if layer == last and position != 0:
            raise ValueError(f"'{part}.{key}' follows the output layer of rl_games' SAC MLP")
        if part == "actor":
            out[key] = f"{ours}.head.{param}" if layer == last else f"{ours}.trunk.net.{layer}.{position}.{param}"
        else:
            q = seq.lower()
            out[key] = f"{ours}.{q}.1.{param}" if layer == last else f"{ours}.{q}.0.net.{layer}.{position}.{param}"
    return out


def model_names_from_rl_games(state: dict[str, Any]) -> dict[tuple[str, str], str]:
    """(rl_games part, key in it) -> rlchain model key, for the three networks and the input normalizer."""
    names: dict[tuple[str, str], str] = {}
    for part in NETWORKS:
        tensors = _strip(state[part])
        for seq in _MLPS[part]:
            keys = [k for k in tensors if k.startswith(seq + ".")]
            names.update({(part, k): v for k, v in _mlp_names(part, seq, keys, tensors).items()})
        unknown = [k for k in tensors if (part, k) not in names]
        if unknown:
            raise ValueError(f"'{part}.{unknown[0]}' has no rlchain name (rlchain reads rl_games' SAC MLPs)")
    for stat in state.get("running_mean_std") or {}:
        if stat not in _NORM_STATS:
            raise ValueError(f"'running_mean_std.{stat}' has no rlchain name")
        names[("running_mean_std", stat)] = f"obs_norm.{_NORM_STATS[stat]}"
    return names


def from_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rl_games SAC checkpoint as rlchain's checkpoint dict: ``model``, ``epoch``, ``frames``,
    ``best_reward`` and ``rl_games_sac_optimizers`` (each rl_games optimizer's state under rlchain's name,
    for :func:`optimizer_states`). Without ``log_alpha`` (rl_games 1.6.5) ``keep_built`` lists it: the model
    keeps the temperature its config starts from, as rl_games 1.6.5 does on resume."""
    names = model_names_from_rl_games(state)
    model: dict[str, Any] = {}
    if state.get("log_alpha") is not None:
        model["log_alpha"] = state["log_alpha"].detach().reshape(()).float()
    for part in (*NETWORKS, "running_mean_std"):
        for key, value in _strip(state.get(part) or {}).items():
            model[names[(part, key)]] = value
    best = state.get("last_mean_rewards", None)
    converted: dict[str, Any] = {
        "model": model,
        "epoch": int(state.get("epoch", 0)),
        "frames": int(state.get("frame", 0)),
        "best_reward": float(best) if best is not None else float("-inf"),
        "rl_games_sac_optimizers": {ours: state[theirs] for theirs, ours in OPTIMIZERS.items()
                                    if isinstance(state.get(theirs), dict)},
    }
    if "log_alpha" not in model:
        converted["keep_built"] = ["log_alpha"]
    if state.get("replay_buffer") is not None:
        converted.setdefault("rl_games_unread", []).append("replay_buffer")
    return converted


def optimizer_states(converted: dict[str, Any], template: dict[str, Any]) -> dict[str, Any]:
    """rlchain's SAC agent state (``template``: its own ``state_dict()``) with rl_games' optimizers' per-parameter
    state and learning rates; rlchain's other group settings and its update count kept."""
    out = dict(template)
    for ours, saved in converted.get("rl_games_sac_optimizers", {}).items():
        mine = template[ours]
        ids = [i for group in mine["param_groups"] for i in group["params"]]
        theirs = [i for group in saved.get("param_groups", []) for i in group["params"]]
        if len(ids) != len(theirs):
            raise ValueError(f"the rl_games {ours} holds {len(theirs)} parameters, rlchain's {len(ids)}")
        per_param = saved.get("state", {})
        groups = [dict(group) for group in mine["param_groups"]]
        lr = saved["param_groups"][0].get("lr") if saved.get("param_groups") else None
        for group in groups:
            if lr is not None:
                group["lr"] = float(lr)
        out[ours] = {"state": {mine_id: per_param[their_id] for mine_id, their_id in zip(ids, theirs)
                               if their_id in per_param}, "param_groups": groups}
    return out


def _rlchain_keys(model: dict[str, Any], part: str) -> list[str]:
    """The keys of ``part``'s MLPs (inside ``_OURS[part]``) that :func:`to_rl_games` writes."""
    prefix = _OURS[part] + "."
    return [k[len(prefix):] for k in model if k.startswith(prefix) and
            any(k[len(prefix):].startswith((hidden, output)) for _, hidden, output in _RLCHAIN_MLPS[part])]


def to_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rlchain SAC checkpoint dict as the dict rl_games 1.6.5 / 2.0 restore (``SACAgent.restore``,
    ``SACPlayer.restore``): the three networks, ``running_mean_std`` when the input is normalized, ``log_alpha``,
    counters, the three optimizers, ``last_mean_rewards`` and ``env_state``."""
    model = dict(state["model"])
    out: dict[str, Any] = {part: {} for part in NETWORKS}
    for part, ours in _OURS.items():
        keys = [k[len(ours) + 1:] for k in model if k.startswith(ours + ".")]
        for seq, hidden, output in _RLCHAIN_MLPS[part]:
            index, end = rl_games_mlp.block_indices(keys, hidden, f"{ours}.")
            for key in keys:
                inner = re.fullmatch(rf"{re.escape(hidden)}(\d+)\.(\d+)\.(\w+)", key)
                if inner is not None:
                    position = index[(int(inner.group(1)), int(inner.group(2)))]
                    out[part][f"{seq}.{position}.{inner.group(3)}"] = model[f"{ours}.{key}"]
                elif key.startswith(output):
                    out[part][f"{seq}.{end}.{key[len(output):]}"] = model[f"{ours}.{key}"]
    network_keys = [k for k in model if k.startswith(("network.", "critic_target."))]
    if sum(len(v) for v in out.values()) != len(network_keys):  # a module that is none of the above
        known = {f"{_OURS[part]}.{k}" for part in NETWORKS for k in _rlchain_keys(model, part)}
        unknown = [k for k in network_keys if k not in known]
        raise ValueError(f"'{unknown[0] if unknown else network_keys[0]}' has no rl_games name (rl_games' SAC "
                         f"MLPs are written)")
    norm = {k.split(".", 1)[1]: v for k, v in model.items() if k.startswith("obs_norm.")}
    if norm:
        out["running_mean_std"] = {theirs: norm[ours] for theirs, ours in _NORM_STATS.items()}
    out["epoch"], out["frame"] = int(state.get("epoch", 0)), int(state.get("frames", 0))
    agent = state.get("agent") or {}
    for theirs, ours in OPTIMIZERS.items():
        if isinstance(agent.get(ours), dict):
            out[theirs] = agent[ours]
    if "log_alpha" in model:
        out["log_alpha"] = model["log_alpha"].detach().clone()
    out["last_mean_rewards"] = best_reward(state)
    out["env_state"] = None
    return out


__all__ = ["best_reward", "from_rl_games", "is_rlchain_sac", "is_sac", "model_names_from_rl_games",
           "optimizer_states", "to_rl_games"]
