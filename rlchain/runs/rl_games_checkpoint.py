"""rl_games checkpoints in and out: pure conversions between rl_games' ``.pth`` dict and rlchain's.

rl_games (1.6.5 and 2.0) saves ``{'model', 'epoch', 'frame', 'optimizer', 'last_mean_rewards', 'env_state'}``
(PPO), its model's state dict named ``a2c_network.*`` with the normalizers ``running_mean_std.*`` (inputs) and
``value_mean_std.*`` (values), every key prefixed ``_orig_mod.`` when the model was compiled. rlchain names
the same tensors ``network.*``, ``obs_norm.*`` and ``value_norm.*``; the MLP trunk's linear layers are
``actor_trunk.mlp.net.<layer>.0`` where rl_games counts the modules of one Sequential (``actor_mlp.<2 * layer>``:
linear, activation, linear, ...). The parameters come in the same order in both, so the
optimizer's per-parameter state carries over by position.

Only tensors, numbers and dicts are read or written: the functions work on what a ``weights_only`` load
returns. Networks converted: rl_games' ``actor_critic`` with plain MLP trunks (shared or separate), continuous
(``mu``, ``sigma``), discrete (``logits``) and multi-discrete heads; another network (CNN, RNN) or an SAC
checkpoint is a ValueError naming the first key that has no rlchain name.
"""

from __future__ import annotations

import re
from typing import Any

COMPILED_PREFIX = "_orig_mod."
ORIGIN = "rl_games"
"""``state['origin']`` of a converted checkpoint (it holds no RNG streams, episodes or env state)."""

_NORMALIZERS = {"running_mean_std": "obs_norm", "value_mean_std": "value_norm"}
_NORM_STATS = {"running_mean": "mean", "running_var": "var", "count": "count"}
_HEADS = ("sigma", "mu", "value", "logits")
_TRUNKS = {"actor_mlp": "actor_trunk", "critic_mlp": "critic_trunk"}


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
    return "actor" in state and "critic" in state and "log_alpha" in state  # rl_games' SAC


def _trunk_names(keys: list[str], rl_prefix: str, ours: str, two_d: set[str]) -> dict[str, str]:
    """rl_games' Sequential ``actor_mlp.<2 * layer>.<p>`` (linear, activation, linear, ...) ->
    ``<ours>.mlp.net.<layer>.0.<p>``. A norm module (a 1-d weight) is refused: rl_games normalizes after the
    activation, rlchain before it, so the same weights would compute another function."""
    out: dict[str, str] = {}
    for key in keys:
        match = re.fullmatch(rf"{re.escape(rl_prefix)}\.(\d+)\.(weight|bias)", key)
        index = int(match.group(1)) if match else -1
        if match is None or index % 2 or f"{rl_prefix}.{index}.weight" not in two_d:
            raise ValueError(f"'a2c_network.{key}' is not a linear layer of a plain MLP (rlchain converts MLP "
                             f"trunks without normalization layers)")
        out[key] = f"network.{ours}.mlp.net.{index // 2}.0.{match.group(2)}"
    return out


def model_names_from_rl_games(model: dict[str, Any]) -> dict[str, str]:
    """rl_games model key -> rlchain model key (keys without ``_orig_mod.``), in rl_games' order."""
    names: dict[str, str] = {}
    network = [k[len("a2c_network."):] for k in model if k.startswith("a2c_network.")]
    two_d = {k for k in network if k.endswith(".weight") and len(getattr(model[f"a2c_network.{k}"], "shape", ())) == 2}
    for rl_trunk, ours in _TRUNKS.items():
        keys = [k for k in network if k.startswith(rl_trunk + ".")]
        names.update({f"a2c_network.{k}": v for k, v in _trunk_names(keys, rl_trunk, ours, two_d).items()})
    for key in network:
        if f"a2c_network.{key}" in names:
            continue
        if key.split(".")[0] not in _HEADS:
            raise ValueError(f"'a2c_network.{key}' has no rlchain name (rlchain reads rl_games' actor_critic "
                             f"with MLP trunks)")
        names[f"a2c_network.{key}"] = f"network.{key}"
    for key in model:
        head, _, stat = key.partition(".")
        if head in _NORMALIZERS:
            if stat not in _NORM_STATS:
                raise ValueError(f"'{key}' has no rlchain name")
            names[key] = f"{_NORMALIZERS[head]}.{_NORM_STATS[stat]}"
        elif not key.startswith("a2c_network."):
            raise ValueError(f"'{key}' has no rlchain name")
    return {k: names[k] for k in model}


def from_rl_games(state: dict[str, Any]) -> dict[str, Any]:
    """An rl_games PPO checkpoint as rlchain's checkpoint dict: ``model`` renamed, ``epoch``, ``frames``,
    ``best_reward``, and ``rl_games_optimizer`` (rl_games' optimizer state and its parameters' rlchain names,
    in order) for :func:`optimizer_state`. ``origin`` says where it came from."""
    if "model" not in state:
        raise ValueError("an rl_games SAC checkpoint (actor / critic / log_alpha); rlchain converts PPO ones")
    model = strip_compiled(dict(state["model"]))
    names = model_names_from_rl_games(model)
    # rl_games' optimizer holds the model's parameters: every a2c_network tensor, in the model's order
    param_names = [names[k] for k in model if k.startswith("a2c_network.")]
    best = state.get("last_mean_rewards", None)
    converted = {
        "origin": ORIGIN,
        "model": {names[k]: v for k, v in model.items()},
        "epoch": int(state.get("epoch", 0)),
        "frames": int(state.get("frame", 0)),
        "best_reward": float(best) if best is not None else float("-inf"),
    }
    if isinstance(state.get("optimizer"), dict):
        converted["rl_games_optimizer"] = {"state_dict": state["optimizer"], "param_names": param_names}
    for key in ("assymetric_vf_nets", "scaler", "pbt_params"):
        if key in state and state[key] is not None:
            converted.setdefault("rl_games_unread", []).append(key)
    return converted


def optimizer_state(converted: dict[str, Any], template: dict[str, Any], names: list[str]) -> dict[str, Any]:
    """rl_games' optimizer state as the state dict of rlchain's optimizer ``template`` (its own
    ``state_dict()``), whose parameters are ``names`` in order: per-parameter state moved by name, the
    learning rate rl_games had; rlchain's other group settings kept."""
    saved = converted["rl_games_optimizer"]
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


def model_names_to_rl_games(model: dict[str, Any]) -> dict[str, str]:
    """rlchain model key -> rl_games model key (the inverse of :func:`model_names_from_rl_games`)."""
    out: dict[str, str] = {}
    for key in model:
        head, _, rest = key.partition(".")
        if head in ("obs_norm", "value_norm"):
            rl_head = next(k for k, v in _NORMALIZERS.items() if v == head)
            stat = next(k for k, v in _NORM_STATS.items() if v == rest)
            out[key] = f"{rl_head}.{stat}"
            continue
        match = re.fullmatch(r"network\.(actor|critic)_trunk\.mlp\.net\.(\d+)\.0\.(weight|bias)", key)
        if match is not None:  # rl_games' Sequential per layer: linear, activation
            trunk, layer, param = match.groups()
            out[key] = f"a2c_network.{trunk}_mlp.{2 * int(layer)}.{param}"
        elif head == "network" and rest.split(".")[0] in _HEADS:
            out[key] = f"a2c_network.{rest}"
        else:
            raise ValueError(f"'{key}' has no rl_games name (rl_games' actor_critic with MLP trunks is written)")
    return out


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
    """An rlchain PPO checkpoint dict as the dict rl_games 1.6.5 / 2.0 restore: ``model`` (``a2c_network.*``,
    ``running_mean_std.*``, ``value_mean_std.*``), ``epoch``, ``frame``, ``optimizer``, ``last_mean_rewards``,
    ``env_state``."""
    model = dict(state["model"])
    _check_same_trunks(model)
    names = model_names_to_rl_games(model)
    out: dict[str, Any] = {"model": {names[k]: v for k, v in model.items()},
                           "epoch": int(state.get("epoch", 0)), "frame": int(state.get("frames", 0))}
    agent = state.get("agent") or {}
    if isinstance(agent.get("optimizer"), dict):
        out["optimizer"] = agent["optimizer"]  # the parameters are in rl_games' order already
    best = state.get("best_reward")
    out["last_mean_rewards"] = float(best) if best is not None and best == best and abs(best) != float("inf") \
        else -1000000000.0
    out["env_state"] = None
    return out


__all__ = ["ORIGIN", "from_rl_games", "is_rl_games_checkpoint", "model_names_from_rl_games",
           "model_names_to_rl_games", "optimizer_state", "strip_compiled", "to_rl_games"]
