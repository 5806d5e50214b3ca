"""rl_games checkpoints in: pure conversions from rl_games' ``.pth`` dict to rlchain's (and the names both
directions share; out: :mod:`rlchain.runs.rl_games_export`).

rl_games (1.6.5 and 2.0) saves ``{'model', 'epoch', 'frame', 'optimizer', 'last_mean_rewards', 'env_state'}``
(PPO), its model's state dict named ``a2c_network.*`` with the normalizers ``running_mean_std.*`` (inputs) and
``value_mean_std.*`` (values), every key prefixed ``_orig_mod.`` when the model was compiled. rlchain names
the same tensors ``network.*``, ``obs_norm.*`` and ``value_norm.*``. rl_games' trunks map to rlchain's
``actor_trunk`` / ``critic_trunk``: the MLP's linear layers ``actor_mlp.<2 * layer>`` (one Sequential: linear,
activation, linear, ...) are ``mlp.net.<layer>.0``; the convolutions ``actor_cnn.<i>`` are ``cnn.net.<i>`` (the
same Sequential); the recurrent layer ``rnn.rnn`` (``a_rnn`` / ``c_rnn`` when separate) and its LayerNorm
``layer_norm`` (``a_layer_norm`` / ``c_layer_norm``) are ``rnn.rnn`` and ``rnn.norm``. rl_games' optimizer
holds the parameters in its modules' registration order, rlchain's in its own: the per-parameter state moves
by name both ways.

Only tensors, numbers and dicts are read or written: the functions work on what a ``weights_only`` load returns.
Networks converted: rl_games' ``resnet_actor_critic`` (IMPALA stages, rnn, mlp) and ``actor_critic`` with cnn
(conv2d; conv1d by the same names), MLP and rnn (lstm / gru, before or after the MLP, layer norm, concatenated
input or output) trunks, shared or separate, continuous (``mu``, ``sigma``), discrete (``logits``) and multi-
discrete heads (rl_games' ``logits.<i>`` per action dimension joined into rlchain's one ``logits``, split again
on export when the file came from rl_games: an rlchain-trained checkpoint does not record the sizes); MLP
normalization layers (rl_games 2.0's ``network.normalization``: after the activation) onto rlchain's
``mlp.norm_after_activation`` blocks (see :mod:`rlchain.runs.rl_games_mlp`); a central value
(``assymetric_vf_nets`` and its optimizer) onto rlchain's ``central_value``; SAC checkpoints in
:mod:`rlchain.runs.rl_games_sac_checkpoint`. Refused with a ValueError naming the first key: normalization layers
inside a cnn (rlchain's has none), D2RL MLPs and other networks; the other way, rlchain's norm before the
activation (rl_games cannot compute it).
"""

from __future__ import annotations

import re
from typing import Any

import torch

from rlchain.runs import rl_games_mlp, rl_games_sac_checkpoint

COMPILED_PREFIX = rl_games_sac_checkpoint.COMPILED_PREFIX
ORIGIN = "rl_games"
"""``state['origin']`` of a converted checkpoint (it holds no RNG streams, episodes or env state)."""

NORMALIZERS = {"running_mean_std": "obs_norm", "value_mean_std": "value_norm"}
NORM_STATS = {"running_mean": "mean", "running_var": "var", "count": "count"}
HEADS = ("sigma", "mu", "value", "logits")
_TRUNKS = {"actor_mlp": "actor_trunk", "critic_mlp": "critic_trunk"}
_CNNS = {"actor_cnn": "actor_trunk", "critic_cnn": "critic_trunk"}
# rl_games' recurrent modules -> (rlchain trunk, module inside it); ``rnn`` / ``layer_norm`` when shared
_RNNS = {"rnn": ("actor_trunk", "rnn.rnn"), "a_rnn": ("actor_trunk", "rnn.rnn"), "c_rnn": ("critic_trunk", "rnn.rnn"),
         "layer_norm": ("actor_trunk", "rnn.norm"), "a_layer_norm": ("actor_trunk", "rnn.norm"),
         "c_layer_norm": ("critic_trunk", "rnn.norm")}
# rl_games' A2CBuilder registers its modules in this order (its optimizer's parameter order); the fixed sigma
# vector (``a2c_network.sigma``, a parameter of the network itself) comes before them all
MODULE_ORDER = ("cnn", "actor_cnn", "critic_cnn", "actor_mlp", "critic_mlp", "rnn", "a_rnn", "c_rnn", "layer_norm",
                 "a_layer_norm", "c_layer_norm", "mlp", "value", "logits", "mu", "sigma")
# rl_games' resnet_actor_critic (``cnn`` IMPALA stages, then ``rnn`` and ``mlp``; never separate): a stage's
# modules -> their place in rlchain's ImpalaStage (conv, max-pool, two residual blocks of act, conv, act, conv)
IMPALA = {"conv.conv": "0", "res_block1.conv1.conv": "2.net.1", "res_block1.conv2.conv": "2.net.3",
           "res_block2.conv1.conv": "3.net.1", "res_block2.conv2.conv": "3.net.3"}
_BUFFERS = ("running_mean", "running_var", "num_batches_tracked")


def strip_compiled(names: dict[str, Any]) -> dict[str, Any]:
    """``names`` without torch.compile's ``_orig_mod.`` anywhere in a key."""
    return {key.replace(COMPILED_PREFIX, ""): value for key, value in names.items()}


def is_rl_games_checkpoint(state: Any) -> bool:
    """Whether ``state`` (a loaded ``.pth``) is an rl_games PPO or SAC checkpoint."""
    if not isinstance(state, dict) or "format" in state:
        return False
    model = state.get("model")
    if isinstance(model, dict):
        return any(key.replace(COMPILED_PREFIX, "").startswith(("a2c_network.", "running_mean_std."))
                   for key in model)
    return rl_games_sac_checkpoint.is_sac(state)


def _dims(model: dict[str, Any], key: str) -> int:
    return len(getattr(model.get(key), "shape", ()))


def _trunk_names(keys: list[str], rl_prefix: str, ours: str, model: dict[str, Any]) -> dict[str, str]:
    """rl_games' Sequential ``actor_mlp.<i>.<p>`` (linear, activation[, norm], linear, ...) ->
    ``<ours>.mlp.net.<layer>.<position>.<p>`` (see :mod:`rlchain.runs.rl_games_mlp`)."""
    tensors = {k: model[f"a2c_network.{k}"] for k in keys}
    where = rl_games_mlp.sequential_layers(tensors, rl_prefix, "a2c_network.")
    out: dict[str, str] = {}
    for key in keys:
        index, param = key[len(rl_prefix) + 1:].split(".", 1)
        layer, position = where[int(index)]
        out[key] = f"network.{ours}.mlp.net.{layer}.{position}.{param}"
    return out


def _cnn_names(keys: list[str], rl_prefix: str, ours: str, model: dict[str, Any]) -> dict[str, str]:
    """rl_games' ``actor_cnn.<i>.<p>`` (conv, activation, conv, ...) -> ``<ours>.cnn.net.<i>.<p>``: the same
    Sequential. A normalization layer after a convolution (network.normalization) has no rlchain place."""
    out: dict[str, str] = {}
    for key in keys:
        match = re.fullmatch(rf"{re.escape(rl_prefix)}\.(\d+)\.(weight|bias)", key)
        if match is None or _dims(model, f"a2c_network.{rl_prefix}.{match.group(1)}.weight") < 3:
            raise ValueError(f"'a2c_network.{key}' is not a convolution (rlchain's cnn has no normalization "
                             f"layers: network.normalization with a cnn cannot be read)")
        out[key] = f"network.{ours}.cnn.net.{match.group(1)}.{match.group(2)}"
    return out


def _impala_name(key: str) -> str:
    """rl_games' resnet ``cnn.<stage>.<module>.<p>`` -> rlchain's ``network.actor_trunk.cnn.stages.<stage>...``."""
    match = re.fullmatch(r"cnn\.(\d+)\.(.+)\.(weight|bias)", key)
    if match is None or match.group(2) not in IMPALA:
        raise ValueError(f"'a2c_network.{key}' has no rlchain name (rlchain's IMPALA stages have no batch norm, "
                         f"attention or zero-init scale)")
    return f"network.actor_trunk.cnn.stages.{match.group(1)}.{IMPALA[match.group(2)]}.{match.group(3)}"


def model_names_from_rl_games(model: dict[str, Any]) -> dict[str, str]:
    """rl_games model key -> rlchain model key (keys without ``_orig_mod.``), in rl_games' order."""
    names: dict[str, str] = {}
    network = [k[len("a2c_network."):] for k in model if k.startswith("a2c_network.")]
    for rl_trunk, ours in _TRUNKS.items():
        keys = [k for k in network if k.startswith(rl_trunk + ".")]
        names.update({f"a2c_network.{k}": v for k, v in _trunk_names(keys, rl_trunk, ours, model).items()})
    resnet = [k for k in network if k.startswith("cnn.")]
    names.update({f"a2c_network.{k}": _impala_name(k) for k in resnet})
    if resnet:  # its MLP is ``mlp``, the trunk's
        keys = [k for k in network if k.startswith("mlp.")]
        names.update({f"a2c_network.{k}": v for k, v in _trunk_names(keys, "mlp", "actor_trunk", model).items()})
    for rl_cnn, ours in _CNNS.items():
        keys = [k for k in network if k.startswith(rl_cnn + ".")]
        names.update({f"a2c_network.{k}": v for k, v in _cnn_names(keys, rl_cnn, ours, model).items()})
    for key in network:
        if f"a2c_network.{key}" in names:
            continue
        module, _, rest = key.partition(".")
        if module in _RNNS:
            trunk, inner = _RNNS[module]
            prefix = "rnn." if module.endswith("rnn") else ""  # LSTMWithDones / GRUWithDones hold ``rnn``
            if not rest.startswith(prefix):
                raise ValueError(f"'a2c_network.{key}' has no rlchain name")
            names[f"a2c_network.{key}"] = f"network.{trunk}.{inner}.{rest[len(prefix):]}"
        elif module in HEADS:
            names[f"a2c_network.{key}"] = f"network.{key}"
        else:
            raise ValueError(f"'a2c_network.{key}' has no rlchain name (rlchain reads rl_games' actor_critic "
                             f"with cnn, mlp and rnn trunks)")
    for key in model:
        head, _, stat = key.partition(".")
        if head in NORMALIZERS:
            if stat not in NORM_STATS:
                raise ValueError(f"'{key}' has no rlchain name")
            names[key] = f"{NORMALIZERS[head]}.{NORM_STATS[stat]}"
        elif not key.startswith("a2c_network."):
            raise ValueError(f"'{key}' has no rlchain name")
    return {k: names[k] for k in model}


def is_parameter(key: str) -> bool:
    """Whether a network key names a parameter (the optimizer's), not a buffer."""
    return key.rsplit(".", 1)[-1] not in _BUFFERS


def from_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rl_games PPO checkpoint as rlchain's checkpoint dict: ``model`` renamed, ``epoch``, ``frames``,
    ``best_reward``, and ``rl_games_optimizer`` (rl_games' optimizer state and its parameters' rlchain names,
    in order) for :func:`optimizer_state`. ``origin`` says where it came from."""
    if "model" not in state:
        return {"origin": ORIGIN, **rl_games_sac_checkpoint.from_rl_games(state)}
    model = strip_compiled(dict(state["model"]))
    optimizer = state.get("optimizer")
    sizes = [int(model[f"a2c_network.logits.{i}.bias"].shape[0]) for i in range(len(model))
             if f"a2c_network.logits.{i}.bias" in model]
    model, optimizer = _joined_logits(model, optimizer if isinstance(optimizer, dict) else None)
    names = model_names_from_rl_games(model)
    # rl_games' optimizer holds the model's parameters: every a2c_network parameter, in the model's order
    param_names = [names[k] for k in model if k.startswith("a2c_network.") and is_parameter(k)]
    best = state.get("last_mean_rewards", None)
    converted = {
        "origin": ORIGIN,
        "model": {names[k]: v for k, v in model.items()},
        "epoch": int(state.get("epoch", 0)),
        "frames": int(state.get("frame", 0)),
        "best_reward": float(best) if best is not None else float("-inf"),
    }
    if optimizer is not None:
        converted["rl_games_optimizer"] = {"state_dict": optimizer, "param_names": param_names}
    if sizes:  # written back per dimension by to_rl_games
        converted["rl_games_logits_sizes"] = sizes
    if isinstance(state.get("assymetric_vf_nets"), dict):
        converted["central_value"], cv_params = central_value_from_rl_games(state["assymetric_vf_nets"])
        if isinstance(state.get("assymetric_vf_optimizer"), dict):
            converted["rl_games_cv_optimizer"] = {"state_dict": state["assymetric_vf_optimizer"],
                                                  "param_names": cv_params}
    for key in ("scaler", "pbt_params"):
        if key in state and state[key] is not None:
            converted.setdefault("rl_games_unread", []).append(key)
    return converted


_LOGITS = re.compile(r"a2c_network\.logits\.(\d+)\.(weight|bias)")


def _joined_logits(model: dict[str, Any], optimizer: dict[str, Any] | None
                   ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """rl_games' multi-discrete head (one Linear per action dimension, ``logits.<i>``) as rlchain's one Linear
    over all of them (``logits``, the dimensions' outputs in order), in the model and in its optimizer's
    per-parameter state (moments concatenated the same way)."""
    heads = sorted({int(m.group(1)) for k in model if (m := _LOGITS.fullmatch(k))})
    if not heads:
        return model, optimizer
    joined: dict[str, Any] = {}
    parts: dict[str, list[str]] = {}  # joined key -> the rl_games keys it holds
    for key, value in model.items():
        match = _LOGITS.fullmatch(key)
        if match is None:
            joined[key] = value
            continue
        name = f"a2c_network.logits.{match.group(2)}"
        if name not in joined:
            parts[name] = [f"a2c_network.logits.{i}.{match.group(2)}" for i in heads]
            joined[name] = torch.cat([model[k] for k in parts[name]], 0)
    if optimizer is None:
        return joined, None
    groups = optimizer.get("param_groups") or []
    old = [k for k in model if k.startswith("a2c_network.") and is_parameter(k)]
    if len(groups) != 1 or len(groups[0]["params"]) != len(old):
        raise ValueError(f"the rl_games optimizer holds {sum(len(g['params']) for g in groups)} parameters in "
                         f"{len(groups)} groups, the network {len(old)}")
    ids = dict(zip(old, groups[0]["params"]))
    per_param = optimizer.get("state", {})
    new = [k for k in joined if k.startswith("a2c_network.") and is_parameter(k)]
    state: dict[int, Any] = {}
    for j, key in enumerate(new):
        pieces = [per_param[ids[k]] for k in parts.get(key, [key]) if ids[k] in per_param]
        if not pieces:
            continue
        state[j] = {field: torch.cat([p[field] for p in pieces], 0)
                    if torch.is_tensor(value) and value.dim() > 0 else value for field, value in pieces[0].items()}
    return joined, {"state": state, "param_groups": [{**groups[0], "params": list(range(len(new)))}]}


def central_value_from_rl_games(nets: dict[str, Any]) -> tuple[dict[str, Any], list[str]]:
    """rl_games' ``assymetric_vf_nets`` (its central value's state dict: ``model.a2c_network.*`` and the model's
    normalizers) as rlchain's central value state dict (``network.trunk.*``, ``network.value.*``, ``obs_norm.*``,
    ``value_norm.*``), and its parameters' names in rl_games' optimizer order."""
    model = strip_compiled(dict(nets))
    outside = [k for k in model if not k.startswith("model.")]
    if outside:
        raise ValueError(f"'assymetric_vf_nets.{outside[0]}' has no rlchain name")
    inner = {k[len("model."):]: v for k, v in model.items()}
    names = {k: _central_name(v) for k, v in model_names_from_rl_games(inner).items()}
    head = [k for k in names if names[k].startswith("network.") and not names[k].startswith(("network.trunk.",
                                                                                             "network.value."))]
    if head:
        raise ValueError(f"'assymetric_vf_nets.model.{head[0]}' has no rlchain name (a central value network has "
                         f"one trunk and the value head)")
    params = [names[k] for k in inner if k.startswith("a2c_network.") and is_parameter(k)]
    return {names[k]: v for k, v in inner.items()}, params


def _central_name(name: str) -> str:
    """An actor-critic name as the central value's: rlchain's critic network has one ``trunk``."""
    return name.replace("network.actor_trunk.", "network.trunk.", 1)


def optimizer_state(converted: dict[str, Any], template: dict[str, Any], names: list[str],
                    key: str = "rl_games_optimizer") -> dict[str, Any]:
    """rl_games' optimizer state as the state dict of rlchain's optimizer ``template`` (its own
    ``state_dict()``), whose parameters are ``names`` in order: per-parameter state moved by name, the
    learning rate rl_games had; rlchain's other group settings kept."""
    saved = converted[key]
    rl_state, rl_names = saved["state_dict"], saved["param_names"]
    position = {name: i for i, name in enumerate(rl_names)}
    missing = [n for n in names if n not in position]
    if missing:
        raise ValueError(f"the rl_games optimizer has no state for '{missing[0]}'")
    per_param = rl_state.get("state", {})
    state = {j: per_param[position[name]] for j, name in enumerate(names) if position[name] in per_param}
    groups = [dict(group) for group in template["param_groups"]]
    lr = rl_state["param_groups"][0].get("lr") if rl_state.get("param_groups") else None
    for group in groups:
        if lr is not None:
            group["lr"] = float(lr)
    return {"state": state, "param_groups": groups}


def resume_agent_states(converted: dict[str, Any], agent: dict[str, Any], names: list[str],
                        cv_agent: dict[str, Any] | None = None, cv_names: list[str] | None = None
                        ) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """rl_games' optimizer layouts on this run's agents, for a resume from a converted checkpoint: PPO's one
    optimizer on ``agent`` (a state dict; its trainable parameters ``names``), the central value's
    (``assymetric_vf_nets``) on ``cv_agent`` (``cv_names``; only when the file has a central value and the run
    one), SAC's three (:func:`rlchain.runs.rl_games_sac_checkpoint.optimizer_states`); each ``lr`` the one
    rl_games had. Returns (agent, central value agent or None); a layout that does not fit raises ValueError
    saying which part."""
    agent = dict(agent)
    if "rl_games_optimizer" in converted and "optimizer" in agent:
        agent["optimizer"] = optimizer_state(converted, agent["optimizer"], names)
        agent["lr"] = float(agent["optimizer"]["param_groups"][0]["lr"])
    if "central_value" not in converted or cv_agent is None:
        cv_agent = None
    elif "rl_games_cv_optimizer" in converted:
        cv_agent = dict(cv_agent)
        try:
            cv_agent["optimizer"] = optimizer_state(converted, cv_agent["optimizer"], cv_names or [],
                                                    key="rl_games_cv_optimizer")
        except ValueError as exc:
            raise ValueError(f"central value: {exc}") from None
        cv_agent["lr"] = float(cv_agent["optimizer"]["param_groups"][0]["lr"])
    if "rl_games_sac_optimizers" in converted:
        try:
            agent = rl_games_sac_checkpoint.optimizer_states(converted, agent)
        except (KeyError, ValueError) as exc:
            raise ValueError(f"the rl_games SAC optimizers do not fit this agent: {exc}") from None
    return agent, cv_agent


__all__ = ["ORIGIN", "central_value_from_rl_games", "from_rl_games", "is_rl_games_checkpoint",
           "model_names_from_rl_games", "optimizer_state", "resume_agent_states", "strip_compiled"]
