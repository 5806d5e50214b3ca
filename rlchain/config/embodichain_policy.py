"""EmbodiChain's ``policy`` block (actor and critic MLPs, a state-independent log-std) -> rlchain's
``params.model`` and ``params.network`` blocks (``actor_critic`` network, ``continuous_a2c_logstd`` model)."""

from __future__ import annotations

from typing import Any

from rlchain.config.embodichain_keys import (
    ACTIVATIONS,
    LOG_STD_BOUNDS,
    MODULE_KEYS,
    NETWORK_KEYS,
    POLICY_FOR,
    reject_unknown,
)
from rlchain.config.errors import ConfigError
from rlchain.errors import did_you_mean


def _mlp(module: Any, path: str, source: str) -> dict[str, Any]:
    if not isinstance(module, dict):
        raise ConfigError(source, path, f"expected a mapping with type and network_cfg, got {module!r}")
    reject_unknown(module, MODULE_KEYS, path, source)
    if str(module.get("type", "")).lower() != "mlp":
        raise ConfigError(source, f"{path}.type", f"expected mlp, got {module.get('type')!r}")
    net = module.get("network_cfg") or {}
    reject_unknown(net, NETWORK_KEYS, f"{path}.network_cfg", source)
    if "hidden_sizes" not in net:
        raise ConfigError(source, f"{path}.network_cfg.hidden_sizes", "required key is missing")
    return net


def _activation(value: Any, path: str, source: str) -> str:
    key = "none" if value is None else str(value).lower()
    if key not in ACTIVATIONS:
        raise ConfigError(source, path, f"{value!r}: expected one of {', '.join(sorted(ACTIVATIONS))}"
                                        f"{did_you_mean(key, ACTIVATIONS)}")
    return ACTIVATIONS[key]


def _gains(net: dict) -> list[float] | None:
    """``orthogonal_init`` as a list of gains (one number: every layer), None when absent."""
    gains = net.get("orthogonal_init")
    if gains is None:
        return None
    return [float(g) for g in (gains if isinstance(gains, list) else [gains])]


def _mlp_block(net: dict, path: str, source: str) -> dict[str, Any]:
    """One ``network_cfg`` as rlchain's ``mlp`` block: units, activation, layer norm, dropout, the first
    orthogonal gain for the hidden layers (rlchain's initializer has one gain per block)."""
    mlp: dict[str, Any] = {"units": [int(u) for u in net["hidden_sizes"]],
                           "activation": _activation(net.get("activation", "elu"), f"{path}.network_cfg.activation",
                                                     source)}
    if net.get("use_layernorm"):
        mlp["normalization"] = "layer_norm"
    if float(net.get("dropout_p") or 0.0):
        mlp["dropout"] = float(net["dropout_p"])
    gains = _gains(net)
    if gains is not None:
        mlp["initializer"] = {"name": "orthogonal_initializer", "gain": gains[0]}
    return mlp


def policy_blocks(policy: dict, algo: str, source: str) -> tuple[dict, dict]:
    """``policy`` (actor / critic MLPs, the initial log-std) -> rlchain's (``params.model``, ``params.network``)
    for the algorithm ``algo``: a continuous actor-critic (ppo) or actor-only (grpo, apg) MLP."""
    kind = str(policy.get("name", "")).lower()
    if kind not in ("actor_critic", "actor_only"):
        raise ConfigError(source, "policy.name", f"expected actor_critic or actor_only, got {policy.get('name')!r}")
    if kind != POLICY_FOR[algo]:
        raise ConfigError(source, "policy.name", f"algorithm {algo} trains an {POLICY_FOR[algo]} policy, got "
                                                 f"{kind}")
    actor = _mlp(policy.get("actor"), "policy.actor", source)
    mlp = _mlp_block(actor, "policy.actor", source)
    gains = _gains(actor)
    mu_init: dict[str, Any] = {"name": "orthogonal_initializer", "gain": gains[-1]} if gains else {"name": "default"}
    separate = kind == "actor_critic"
    network: dict[str, Any] = {"name": "actor_critic", "separate": separate}
    if separate:
        path = "policy.critic"
        critic = _mlp(policy.get("critic"), path, source)
        critic_mlp = _mlp_block(critic, path, source)
        if critic_mlp != mlp:  # a critic of its own (sizes, activation, norm, dropout or init differ)
            network["critic_mlp"] = critic_mlp
        network["value_activation"] = _activation(critic.get("last_activation"), f"{path}.network_cfg."
                                                  "last_activation", source)
    elif policy.get("critic") is not None:
        raise ConfigError(source, "policy.critic", "an actor_only policy has no critic; remove the block")
    space = {"continuous": {"mu_activation": _activation(actor.get("last_activation"), "policy.actor.network_cfg."
                                                                                        "last_activation", source),
                            "sigma_activation": "None", "mu_init": mu_init,
                            "sigma_init": {"name": "const_initializer",
                                           "val": float(policy.get("initial_log_std", 0.0))},
                            "fixed_sigma": True, "logstd_bounds": LOG_STD_BOUNDS}}
    network.update(space=space, mlp=mlp)
    return {"name": "continuous_a2c_logstd"}, network
