"""rlchain checkpoints out to rl_games: an rlchain PPO (or SAC) checkpoint dict as the dict rl_games 1.6.5 / 2.0
restore, the inverse of :mod:`rlchain.runs.rl_games_checkpoint` (whose module docstring lays out both
namings). The model's tensors are renamed and put in rl_games' registration order, the optimizer's
per-parameter state with them; a multi-discrete head read from rl_games is split back into its heads.
"""

from __future__ import annotations

import re
from typing import Any

import torch

from rlchain.runs import rl_games_mlp, rl_games_sac_checkpoint
from rlchain.runs.rl_games_checkpoint import HEADS, IMPALA, MODULE_ORDER, NORM_STATS, NORMALIZERS, is_parameter


def model_names_to_rl_games(model: dict[str, Any]) -> dict[str, str]:
    """rlchain model key -> rl_games model key (the inverse of :func:`model_names_from_rl_games`)."""
    out: dict[str, str] = {}
    blocks: dict[str, dict[tuple[int, int], int]] = {}  # per trunk: (layer, position) -> rl_games' index
    separate = any(key.startswith("network.critic_trunk.") for key in model)
    resnet = any(key.startswith("network.actor_trunk.cnn.stages.") for key in model)
    for key in model:
        head, _, rest = key.partition(".")
        if head in ("obs_norm", "value_norm"):
            rl_head = next(k for k, v in NORMALIZERS.items() if v == head)
            stat = next(k for k, v in NORM_STATS.items() if v == rest)
            out[key] = f"{rl_head}.{stat}"
            continue
        impala = re.fullmatch(r"network\.actor_trunk\.cnn\.stages\.(\d+)\.(.+)\.(weight|bias)", key)
        if impala is not None:  # rl_games' resnet_actor_critic: its cnn, mlp and rnn are not the trunk's
            stage, module, param = impala.groups()
            theirs = next((k for k, v in IMPALA.items() if v == module), None)
            if theirs is None:
                raise ValueError(f"'{key}' has no rl_games name")
            out[key] = f"a2c_network.cnn.{stage}.{theirs}.{param}"
            continue
        mlp = re.fullmatch(r"network\.(actor|critic)_trunk\.mlp\.net\.(\d+)\.(\d+)\.(\w+)", key)
        cnn = re.fullmatch(r"network\.(actor|critic)_trunk\.cnn\.net\.(\d+)\.(weight|bias)", key)
        rnn = re.fullmatch(r"network\.(actor|critic)_trunk\.rnn\.(rnn|norm)\.(\w+)", key)
        if mlp is not None:  # rl_games' one Sequential: linear, activation[, norm] per layer
            trunk, layer, position, param = mlp.groups()
            prefix = f"network.{trunk}_trunk.mlp.net."
            if prefix not in blocks:
                blocks[prefix] = rl_games_mlp.block_indices([k for k in model if k.startswith(prefix)], prefix)[0]
            rl_mlp = "mlp" if resnet else f"{trunk}_mlp"
            out[key] = f"a2c_network.{rl_mlp}.{blocks[prefix][(int(layer), int(position))]}.{param}"
        elif cnn is not None:  # the same Sequential: conv, activation, ...
            trunk, index, param = cnn.groups()
            out[key] = f"a2c_network.{trunk}_cnn.{index}.{param}"
        elif rnn is not None:
            trunk, module, param = rnn.groups()
            prefix = (trunk[0] + "_") if separate else ""
            out[key] = f"a2c_network.{prefix}rnn.rnn.{param}" if module == "rnn" \
                else f"a2c_network.{prefix}layer_norm.{param}"
        elif head == "network" and rest.split(".")[0] in HEADS:
            out[key] = f"a2c_network.{rest}"
        else:
            raise ValueError(f"'{key}' has no rl_games name (rl_games' actor_critic with cnn, mlp and rnn "
                             f"trunks is written)")
    return out


def _rl_games_rank(key: str) -> tuple[int, int]:
    """Where rl_games' model puts ``key``: its normalizers, then the network's modules in registration order."""
    head, _, rest = key.partition(".")
    if head != "a2c_network":
        return (0 if head == "value_mean_std" else 1, 0)
    module = rest.split(".")[0]
    if rest == "sigma":  # the fixed sigma: a parameter of the network itself, first
        return (2, -1)
    return (2, MODULE_ORDER.index(module) if module in MODULE_ORDER else len(MODULE_ORDER))


def _reordered_optimizer(optimizer: dict[str, Any], ours: list[str], theirs: list[str],
                         names: dict[str, str]) -> dict[str, Any]:
    """rlchain's optimizer state (parameters ``ours`` in order) with its per-parameter state in rl_games' order
    (``theirs``, rl_games names; ``names``: ours -> theirs)."""
    groups = optimizer.get("param_groups") or []
    if len(groups) != 1 or len(groups[0]["params"]) != len(ours):
        raise ValueError(f"the optimizer holds {sum(len(g['params']) for g in groups)} parameters in "
                         f"{len(groups)} groups, the network {len(ours)} (rl_games has one group)")
    position = {names[name]: i for i, name in enumerate(ours)}
    saved_ids = groups[0]["params"]
    per_param = optimizer.get("state", {})
    state = {j: per_param[saved_ids[position[name]]] for j, name in enumerate(theirs)
             if saved_ids[position[name]] in per_param}
    return {"state": state, "param_groups": [{**groups[0], "params": list(range(len(theirs)))}]}


def _check_same_trunks(model: dict[str, Any]) -> None:
    """rl_games' separate network builds the critic from the actor's mlp block: a critic trunk of other
    layer sizes (rlchain's ``network.critic_mlp``) has no rl_games form."""
    critic = {k: tuple(v.shape) for k, v in model.items() if k.startswith("network.critic_trunk.")}
    actor = {k.replace("network.actor_trunk.", "network.critic_trunk.", 1): tuple(v.shape)
             for k, v in model.items() if k.startswith("network.actor_trunk.")}
    if critic and critic != actor:
        raise ValueError("the critic's layers differ from the actor's (network.critic_mlp); rl_games' separate "
                         "actor_critic gives both the one mlp block")


def to_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rlchain PPO or SAC checkpoint dict as the dict rl_games 1.6.5 / 2.0 restore. PPO: ``model``
    (``a2c_network.*``, ``running_mean_std.*``, ``value_mean_std.*``, in rl_games' order), ``epoch``,
    ``frame``, ``optimizer`` (its per-parameter state in rl_games' parameter order), ``last_mean_rewards``,
    ``env_state``; SAC: see :func:`rlchain.runs.rl_games_sac_checkpoint.to_rl_games`."""
    model = dict(state["model"])
    if rl_games_sac_checkpoint.is_rlchain_sac(model):
        return rl_games_sac_checkpoint.to_rl_games(state)
    space = (((state.get("config") or {}).get("params") or {}).get("network") or {}).get("space") or {}
    sizes = state.get("rl_games_logits_sizes")
    if "multi_discrete" in space and not sizes:
        raise ValueError("'network.logits' is one head over every action dimension: rl_games holds one per "
                         "dimension, and the checkpoint does not record their sizes (multi-discrete is read, "
                         "not written)")
    _check_same_trunks(model)
    names = model_names_to_rl_games(model)
    order = sorted(model, key=lambda k: _rl_games_rank(names[k]))  # stable: a module's own order is kept
    out: dict[str, Any] = {"model": {names[k]: model[k] for k in order},
                           "epoch": int(state.get("epoch", 0)), "frame": int(state.get("frames", 0))}
    agent = state.get("agent") or {}
    if isinstance(agent.get("optimizer"), dict):
        ours = [k for k in model if k.startswith("network.") and is_parameter(k)]
        theirs = [names[k] for k in order if k.startswith("network.") and is_parameter(k)]
        out["optimizer"] = _reordered_optimizer(agent["optimizer"], ours, theirs, names)
    if isinstance(state.get("central_value"), dict):
        cv_agent = state.get("central_value_agent") or {}
        out["assymetric_vf_nets"], cv_optimizer = _central_value_to_rl_games(state["central_value"],
                                                                             cv_agent.get("optimizer"))
        if cv_optimizer is not None:
            out["assymetric_vf_optimizer"] = cv_optimizer
    if sizes:
        out["model"], out["optimizer"] = _split_logits(out["model"], out.get("optimizer"), list(sizes))
        out = {k: v for k, v in out.items() if v is not None}
    out["last_mean_rewards"] = rl_games_sac_checkpoint.best_reward(state)
    out["env_state"] = None
    return out


def own_network_to_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rlchain checkpoint of a network written the rl_games way (a user's ``A2CBuilder`` / ``BaseNetwork``
    subclass or ``SACBuilder``, whose modules carry rl_games' own names) as the dict rl_games restores.

    PPO: ``model`` with the network under ``a2c_network.`` and the normalizers as ``value_mean_std.*`` /
    ``running_mean_std.*`` (rl_games' order: normalizers first, then the network in its own order), ``epoch``,
    ``frame``, ``optimizer`` (one group over the network's parameters, in their order, as rl_games builds it).
    SAC (``algo: sac``): ``actor``, ``critic``, ``critic_target``, ``running_mean_std``, ``log_alpha``, the three
    optimizers and the counters, as :func:`rlchain.runs.rl_games_sac_checkpoint.to_rl_games` writes them."""
    model = dict(state["model"])
    if state.get("algo") == "sac":
        return _own_sac_to_rl_games(state, model)
    names: dict[str, str] = {}
    for key in model:
        head, _, rest = key.partition(".")
        if head == "network":
            names[key] = f"a2c_network.{rest}"
        else:
            names[key] = _normalizer_name(key)
    order = sorted(model, key=lambda k: _rl_games_rank(names[k])[0])  # stable: the network keeps its own order
    out: dict[str, Any] = {"model": {names[k]: model[k] for k in order},
                           "epoch": int(state.get("epoch", 0)), "frame": int(state.get("frames", 0))}
    optimizer = (state.get("agent") or {}).get("optimizer")
    if isinstance(optimizer, dict):
        ours = [k for k in model if k.startswith("network.") and is_parameter(k)]
        out["optimizer"] = _reordered_optimizer(optimizer, ours, [names[k] for k in ours], names)
    out["last_mean_rewards"] = rl_games_sac_checkpoint.best_reward(state)
    return out


def _normalizer_name(key: str) -> str:
    """rl_games' name of an rlchain normalizer's statistic (``obs_norm.mean`` -> ``running_mean_std.running_mean``);
    any other key is a ValueError: rl_games' model has no place for it."""
    head, _, rest = key.partition(".")
    if head not in NORMALIZERS.values() or rest not in NORM_STATS.values():
        raise ValueError(f"'{key}' is outside the network and its normalizers: rl_games' model has no place for it")
    rl_head = next(k for k, v in NORMALIZERS.items() if v == head)
    return f"{rl_head}.{next(k for k, v in NORM_STATS.items() if v == rest)}"


def _own_sac_to_rl_games(state: dict[str, Any], model: dict[str, Any]) -> dict[str, Any]:
    """The SAC half of :func:`own_network_to_rl_games`: each network's state dict under its rl_games key."""
    parts = {"network.actor.": "actor", "network.critic.": "critic", "critic_target.": "critic_target"}
    out: dict[str, Any] = {part: {} for part in parts.values()}
    for key, value in model.items():
        prefix = next((p for p in parts if key.startswith(p)), None)
        if key.startswith("network.critic_target."):  # the builder's own copy: rlchain's SAC trains the model's
            continue
        if prefix is not None:
            out[parts[prefix]][key[len(prefix):]] = value
        elif key == "log_alpha":
            out["log_alpha"] = value.detach().clone()
        else:
            out.setdefault("running_mean_std", {})[_normalizer_name(key).split(".", 1)[1]] = value
    out["epoch"], out["frame"] = int(state.get("epoch", 0)), int(state.get("frames", 0))
    agent = state.get("agent") or {}
    for theirs, ours in rl_games_sac_checkpoint.OPTIMIZERS.items():
        if isinstance(agent.get(ours), dict):
            out[theirs] = agent[ours]
    out["last_mean_rewards"] = rl_games_sac_checkpoint.best_reward(state)
    return out


def _split_logits(model: dict[str, Any], optimizer: dict[str, Any] | None, sizes: list[int]
                  ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """The inverse of rl_games_checkpoint's ``_joined_logits``: rlchain's one ``logits`` head back as rl_games'
    ``logits.<i>`` of ``sizes`` outputs each, in the model and its optimizer state (rl_games' order)."""
    out: dict[str, Any] = {}
    parts: dict[str, list[str]] = {}
    for key, value in model.items():
        match = re.fullmatch(r"a2c_network\.logits\.(weight|bias)", key)
        if match is None:
            out[key] = value
            continue
        parts[key] = [f"a2c_network.logits.{i}.{match.group(1)}" for i in range(len(sizes))]
        for name, piece in zip(parts[key], torch.split(value, sizes, 0)):
            out[name] = piece.clone()
    def head(key: str) -> int:  # rl_games' ModuleList: logits.0.weight, logits.0.bias, logits.1.weight, ...
        match = re.match(r"a2c_network\.logits\.(\d+)\.", key)
        return int(match.group(1)) if match else 0

    out = dict(sorted(out.items(), key=lambda kv: (_rl_games_rank(kv[0]), head(kv[0]))))
    if optimizer is None:
        return out, None
    old = [k for k in model if k.startswith("a2c_network.") and is_parameter(k)]
    new = [k for k in out if k.startswith("a2c_network.") and is_parameter(k)]
    per_param = optimizer.get("state", {})
    pieces: dict[str, Any] = {}
    for i, key in enumerate(old):
        if i not in per_param:
            continue
        if key not in parts:
            pieces[key] = per_param[i]
            continue
        split = {f: torch.split(v, sizes, 0) if torch.is_tensor(v) and v.dim() > 0 else None
                 for f, v in per_param[i].items()}
        for j, name in enumerate(parts[key]):
            pieces[name] = {f: split[f][j].clone() if split[f] is not None else v for f, v in per_param[i].items()}
    state = {j: pieces[name] for j, name in enumerate(new) if name in pieces}
    return out, {"state": state, "param_groups": [{**optimizer["param_groups"][0], "params": list(range(len(new)))}]}


def _central_value_to_rl_games(model: dict[str, Any], optimizer: dict[str, Any] | None
                               ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """rlchain's central value state dict (and its optimizer's state) as rl_games' ``assymetric_vf_nets``
    (``model.*``, uncompiled names: rl_games compiles after it restores) and ``assymetric_vf_optimizer``."""
    renamed = {k.replace("network.trunk.", "network.actor_trunk.", 1): k for k in model}
    names = model_names_to_rl_games(dict.fromkeys(renamed))
    order = sorted(renamed, key=lambda k: _rl_games_rank(names[k]))
    nets = {f"model.{names[k]}": model[renamed[k]] for k in order}
    if not isinstance(optimizer, dict):
        return nets, None
    ours = [k for k in renamed if k.startswith("network.") and is_parameter(k)]
    theirs = [names[k] for k in order if k.startswith("network.") and is_parameter(k)]
    return nets, _reordered_optimizer(optimizer, ours, theirs, names)


__all__ = ["model_names_to_rl_games", "to_rl_games", "own_network_to_rl_games"]
