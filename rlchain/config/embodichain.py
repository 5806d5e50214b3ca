"""EmbodiChain's ``train_config.json`` (``trainer`` / ``policy`` / ``algorithm``) -> an rl_games-style
``{"params": ...}`` dict with EmbodiChain's meaning, which then goes through the usual typed parse.

The one place that knows EmbodiChain's keys. Where EmbodiChain's PPO differs from rl_games' defaults the
translation says so explicitly: no value clipping, no observation or value normalizers, no action clipping
or rescaling (their Gaussian policy's raw sample goes to the env), time-outs end the return like
terminations (no bootstrap), the value loss ``vf_coef * MSE`` (rlchain's ``0.5 * critic_coef``),
a state-independent log-std clamped to [-5, 2], frequencies in env steps turned into whole epochs (rounded
up), steps counted as ``iterations * buffer_size * num_envs`` (per process). A key EmbodiChain ignores
silently is an error here, with a did-you-mean. Old layouts (``rollout_steps``, a flat
``algorithm.cfg.learning_rate``) read with a warning. See docs/embodichain.md.
"""

from __future__ import annotations

import inspect
import json
import math
import os
from typing import Any

import yaml

from rlchain.config.compat import warn_once
from rlchain.config.errors import ConfigError
from rlchain.errors import did_you_mean
from rlchain.registry import ENVS

TOP_KEYS = ("trainer", "policy", "algorithm")
TRAINER_KEYS = {
    "exp_name", "gym_config", "learning_env", "seed", "device", "headless", "gpu_id", "num_envs", "iterations",
    "buffer_size", "rollout_steps", "enable_eval", "num_eval_envs", "num_eval_episodes", "eval_freq",
    "save_freq", "eval_seed", "best_eval_metric", "best_eval_mode", "use_wandb", "wandb_project_name", "events",
    "renderer", "distributed", "total_timesteps", "segment_length", "update_horizon", "deterministic_actions",
    "save_frequency_updates", "enable_rt",
}
SIM_ONLY_KEYS = ("headless", "gpu_id", "renderer", "enable_rt")  # DexSim's window, GPU, renderer, ray tracing
POLICY_KEYS = {"name", "actor", "critic", "initial_log_std", "action_dim"}
MODULE_KEYS = {"type", "network_cfg"}
NETWORK_KEYS = {"hidden_sizes", "activation", "last_activation", "use_layernorm", "dropout_p", "orthogonal_init"}
ALGORITHM_KEYS = {"name", "cfg"}
COMMON_CFG = {"optimizer", "lr_scheduler", "batch_size", "gamma", "gae_lambda", "max_grad_norm", "device",
              "learning_rate"}
ALGO_CFG = {
    "ppo": COMMON_CFG | {"n_epochs", "clip_coef", "ent_coef", "vf_coef"},
    "grpo": COMMON_CFG | {"n_epochs", "clip_coef", "ent_coef", "kl_coef", "group_size", "eps",
                          "reset_every_rollout", "truncate_at_first_done", "shared_starts"},
    "apg": COMMON_CFG | {"ent_coef", "skip_nonfinite_updates"},
}
RLCHAIN_ALGO = {"ppo": "a2c_continuous", "grpo": "grpo", "apg": "apg"}
POLICY_FOR = {"ppo": "actor_critic", "grpo": "actor_only", "apg": "actor_only"}
ACTIVATIONS = {"relu": "relu", "elu": "elu", "tanh": "tanh", "sigmoid": "sigmoid", "selu": "selu",
               "gelu": "gelu", "silu": "swish", "swish": "swish", "softplus": "softplus", "none": "None",
               "identity": "None"}
CAMERA_EVENTS = ("record_camera_data", "record_camera_data_async")
# EmbodiChain's defaults where a key is absent (train.py, utils/config.py, algo/*.py); a learning_env run
# (its _train_learning_env) has its own for a few trainer keys
DEFAULTS = {"seed": 1, "iterations": 250, "buffer_size": 2048, "eval_freq": 10000, "save_freq": 50000,
            "num_eval_episodes": 5, "num_eval_envs": 4, "num_envs": 64, "learning_rate": 3e-4, "batch_size": 64,
            "gamma": 0.99, "gae_lambda": 0.95, "max_grad_norm": 0.5, "n_epochs": 10, "clip_coef": 0.2,
            "vf_coef": 0.5}
LEARNING_ENV_DEFAULTS = {"buffer_size": 256, "eval_freq": 0, "save_freq": 0, "num_eval_envs": 16}
ENT_DEFAULT = {"ppo": 0.01, "grpo": 0.0, "apg": 0.0}
LOG_STD_BOUNDS = [-5.0, 2.0]


def is_embodichain(raw: Any) -> bool:
    """Whether a config dict is in EmbodiChain's layout (a ``trainer`` block, no ``params``)."""
    return isinstance(raw, dict) and "params" not in raw and "trainer" in raw


def split_overrides(overrides: list[str]) -> tuple[list[str], list[str]]:
    """Overrides on EmbodiChain's keys (``trainer.*``, ``policy.*``, ``algorithm.*``) and the rest (rlchain's
    ``params.*``, applied after the translation)."""
    ours = [o for o in overrides if o.split("=", 1)[0].split(".")[0] in TOP_KEYS]
    return ours, [o for o in overrides if o not in ours]


def apply_overrides(raw: dict[str, Any], overrides: list[str], source: str) -> dict[str, Any]:
    """``trainer.gym_config=Name`` style overrides (value parsed as YAML) on the EmbodiChain dict."""
    import copy

    out = copy.deepcopy(raw)
    for item in overrides:
        key, text = item.split("=", 1)
        parts = key.strip().split(".")
        node = out
        for i, part in enumerate(parts[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError(source, ".".join(parts[: i + 1]), "override goes through a non-mapping key")
        try:
            node[parts[-1]] = yaml.safe_load(text)
        except yaml.YAMLError:
            node[parts[-1]] = text
    return out


def _unknown(keys: Any, known: set[str], path: str, source: str) -> None:
    for key in keys:
        if key not in known:
            hint = did_you_mean(key, known) or f"; known keys: {', '.join(sorted(known))}"
            raise ConfigError(source, f"{path}.{key}", f"unknown key (EmbodiChain ignores it silently){hint}")


def _block(raw: dict, key: str, source: str, path: str = "") -> dict:
    value = raw.get(key)
    where = f"{path}.{key}" if path else key
    if value is None:
        raise ConfigError(source, where, "required block is missing")
    if not isinstance(value, dict):
        raise ConfigError(source, where, f"expected a mapping, got {value!r}")
    return value


def translate(raw: dict[str, Any], source: str) -> dict[str, Any]:
    """EmbodiChain's config dict -> rlchain's ``{"params": ...}`` dict (see the module docstring)."""
    for key in raw:
        if key not in TOP_KEYS:
            raise ConfigError(source, key, f"unknown top-level key{did_you_mean(key, TOP_KEYS)}; an EmbodiChain "
                                           f"config has trainer, policy and algorithm")
    trainer = _block(raw, "trainer", source)
    policy = _block(raw, "policy", source)
    algorithm = _block(raw, "algorithm", source)
    _unknown(trainer, TRAINER_KEYS, "trainer", source)
    _unknown(policy, POLICY_KEYS, "policy", source)
    _unknown(algorithm, ALGORITHM_KEYS, "algorithm", source)
    name = str(algorithm.get("name", "")).lower()
    if name not in ALGO_CFG:
        raise ConfigError(source, "algorithm.name", f"expected one of {', '.join(ALGO_CFG)}, got "
                                                    f"{algorithm.get('name')!r}{did_you_mean(name, ALGO_CFG)}")
    cfg = algorithm.get("cfg") or {}
    if not isinstance(cfg, dict):
        raise ConfigError(source, "algorithm.cfg", f"expected a mapping, got {cfg!r}")
    _unknown(cfg, ALGO_CFG[name], "algorithm.cfg", source)
    for key in SIM_ONLY_KEYS:
        if key in trainer:
            warn_once(source, f"trainer.{key}", "a DexSim simulator setting; no effect on rlchain's envs")

    defaults = {**DEFAULTS, **(LEARNING_ENV_DEFAULTS if "learning_env" in trainer else {})}
    env_name, env_config = resolve_env(trainer, source)
    if "device" not in env_config and "device" in inspect.signature(ENVS.get(env_name)).parameters:
        env_config["device"] = str(trainer.get("device", "cpu"))  # EmbodiChain's envs live on the sim device
    num_envs = int(trainer.get("num_envs", defaults["num_envs"]))
    horizon = int(_renamed((trainer, "trainer.rollout_steps"), (trainer, "trainer.buffer_size"),
                           defaults["buffer_size"], source))
    if name == "apg":
        horizon = int(trainer.get("segment_length", 16))
        if int(trainer.get("update_horizon", horizon)) != horizon:
            raise ConfigError(source, "trainer.update_horizon", "rlchain's APG takes one optimizer step per "
                                                                "segment: set it to segment_length or remove it")
    elif any(k in trainer for k in ("segment_length", "update_horizon", "deterministic_actions",
                                    "save_frequency_updates")):
        key = next(k for k in ("segment_length", "update_horizon", "deterministic_actions", "save_frequency_updates")
                   if k in trainer)
        raise ConfigError(source, f"trainer.{key}", f"an APG key; algorithm {name} does not read it")
    world = int(os.environ.get("WORLD_SIZE", "1")) if trainer.get("distributed") else 1
    frames_per_epoch = horizon * num_envs * world
    config: dict[str, Any] = {
        "name": str(trainer.get("exp_name", "generic_exp")),
        "env_name": env_name,
        "env_config": env_config,
        "device": str(trainer.get("device", "cpu")),
        "num_actors": num_envs,
        "horizon_length": horizon,
        "max_epochs": int(trainer.get("iterations", DEFAULTS["iterations"])),
        "gamma": float(cfg.get("gamma", DEFAULTS["gamma"])),
        "normalize_input": False,
        "clip_actions": False,
        "print_stats": True,
        "callbacks": ["rlchain.training.embodichain_tags:EmbodiChainTags"],
        # --play: the evaluation's episode count and its deterministic actions
        "player": {"games_num": int(trainer.get("num_eval_episodes", defaults["num_eval_episodes"])),
                   "deterministic": True},
        "save_frequency_frames": max(0, int(trainer.get("save_freq", defaults["save_freq"]))),
        "checkpoint_names": "embodichain",  # <exp>_step_<N>.pt, <exp>_best.pt
    }
    if name == "apg":  # EmbodiChain's differentiable trainer counts saves in updates (= segments here)
        config["save_frequency"] = int(trainer.get("save_frequency_updates", 0))
        config["save_frequency_frames"] = 0
        config["deterministic_actions"] = bool(trainer.get("deterministic_actions", False))
    if "total_timesteps" in trainer:
        config["max_frames"] = int(trainer["total_timesteps"])
        config["max_epochs"] = -1
    if trainer.get("distributed"):
        config["multi_gpu"] = True
    config.update(_evaluation(trainer, frames_per_epoch, defaults, source))
    config.update(_optimizer(cfg, source))
    config.update(_algo_keys(name, cfg, num_envs * horizon, source))
    if trainer.get("use_wandb"):
        warn_once(source, "trainer.use_wandb", "pass --track (and --wandb-project-name "
                  f"{trainer.get('wandb_project_name', 'embodichain-generic')}) to mirror the run to W&B")
    events = _events(trainer.get("events"), bool(trainer.get("enable_eval")), source)
    if events:
        config["events"] = events
    model, network = _policy(policy, name, source)
    params = {"seed": int(trainer.get("seed", DEFAULTS["seed"])), "algo": {"name": RLCHAIN_ALGO[name]},
              "model": model, "network": network, "config": config}
    return {"params": params}


def _renamed(old: tuple[dict, str], new: tuple[dict, str], default: Any, source: str) -> Any:
    """A key of the old layout and its new place, each (block, dotted path): the new one's value, else the old
    one's with a warning, else ``default``; both given is an error."""
    (old_block, old_path), (new_block, new_path) = old, new
    old_key, new_key = old_path.rsplit(".", 1)[1], new_path.rsplit(".", 1)[1]
    if old_key not in old_block:
        return new_block.get(new_key, default)
    if new_key in new_block:
        raise ConfigError(source, old_path, f"both {old_path} (old layout) and {new_path} given; keep {new_path}")
    warn_once(source, old_path, f"old layout, read as {new_path}")
    return old_block[old_key]


def _epochs(steps: Any, frames_per_epoch: int) -> int:
    """An EmbodiChain frequency in env steps as whole epochs (at least 1; 0 stays off)."""
    steps = int(steps)
    return 0 if steps <= 0 else max(1, math.ceil(steps / frames_per_epoch))


def _evaluation(trainer: dict, frames_per_epoch: int, defaults: dict, source: str) -> dict[str, Any]:
    if not trainer.get("enable_eval"):
        return {}
    metric = trainer.get("best_eval_metric", "eval/avg_reward")
    mode = trainer.get("best_eval_mode", "max")
    if mode not in ("max", "min"):
        raise ConfigError(source, "trainer.best_eval_mode", f"expected max or min, got {mode!r}")
    select = {"eval/avg_reward": "evaluation", "eval/success_rate": "evaluation_success",
              "eval/avg_length": "evaluation_length"}
    if metric not in select:
        warn_once(source, "trainer.best_eval_metric", f"{metric}: rlchain's best checkpoint follows "
                  f"{', '.join(select)}; it follows eval/avg_reward ({mode})")
    block = {"interval": _epochs(trainer.get("eval_freq", defaults["eval_freq"]), frames_per_epoch),
             "games": int(trainer.get("num_eval_episodes", defaults["num_eval_episodes"])),
             "num_envs": int(trainer.get("num_eval_envs", defaults["num_eval_envs"])),
             "seed": int(trainer.get("eval_seed", int(trainer.get("seed", DEFAULTS["seed"])) + 10_000)),
             "select_best": select.get(metric, "evaluation"), "best_mode": mode}
    if block["interval"] == 0:
        return {}
    return {"evaluation": block, "save_best_after": 0}  # theirs saves <exp>_best.pt from the first evaluation


def _optimizer(cfg: dict, source: str) -> dict[str, Any]:
    optimizer = cfg.get("optimizer") or {}
    if not isinstance(optimizer, dict):
        raise ConfigError(source, "algorithm.cfg.optimizer", f"expected a mapping, got {optimizer!r}")
    _unknown(optimizer, {"name", "learning_rate", "kwargs"}, "algorithm.cfg.optimizer", source)
    lr = float(_renamed((cfg, "algorithm.cfg.learning_rate"), (optimizer, "algorithm.cfg.optimizer.learning_rate"),
                        DEFAULTS["learning_rate"], source))
    opt_name = str(optimizer.get("name", "adam")).lower()
    if opt_name != "adam":
        raise ConfigError(source, "algorithm.cfg.optimizer.name", f"{opt_name!r}: rlchain trains with Adam; "
                                                                  "adamw, sgd and rmsprop are not implemented")
    out: dict[str, Any] = {"learning_rate": lr, "lr_schedule": None}
    kwargs = dict(optimizer.get("kwargs") or {})
    if "weight_decay" in kwargs:
        out["weight_decay"] = float(kwargs.pop("weight_decay"))
    if kwargs:
        raise ConfigError(source, f"algorithm.cfg.optimizer.kwargs.{next(iter(kwargs))}",
                          "not supported (rlchain's Adam takes weight_decay only)")
    scheduler = cfg.get("lr_scheduler") or {}
    sched_name = scheduler.get("name") if isinstance(scheduler, dict) else scheduler
    if sched_name in (None, "none", "constant"):
        return out
    if sched_name != "linear":
        raise ConfigError(source, "algorithm.cfg.lr_scheduler.name", f"{sched_name!r}: rlchain reads linear "
                                                                     "(with kwargs.end_factor) or none")
    sched_kwargs = dict(scheduler.get("kwargs") or {})
    end = float(sched_kwargs.pop("end_factor", 0.0))
    sched_kwargs.pop("start_factor", None) if sched_kwargs.get("start_factor", 1.0) == 1.0 else None
    sched_kwargs.pop("total_iters", None)  # bound to the run's length, as EmbodiChain's bind_schedule does
    if sched_kwargs:
        raise ConfigError(source, f"algorithm.cfg.lr_scheduler.kwargs.{next(iter(sched_kwargs))}",
                          "not supported (linear takes end_factor)")
    out.update(lr_schedule="linear", min_lr=lr * end)
    return out


def _minibatch(batch_size: int, batch: int, source: str) -> int:
    """EmbodiChain's batch_size as rlchain's minibatch_size: all of the batch when larger (one minibatch, as
    theirs), else the largest divisor of the batch not above it (theirs ends with a short minibatch)."""
    if batch_size >= batch:
        return batch
    size = batch_size
    while batch % size:
        size -= 1
    if size != batch_size:
        warn_once(source, "algorithm.cfg.batch_size", f"{batch_size} does not divide the rollout of {batch} "
                  f"steps; rlchain uses minibatches of {size}")
    return size


def _algo_keys(name: str, cfg: dict, batch: int, source: str) -> dict[str, Any]:
    out: dict[str, Any] = {
        "entropy_coef": float(cfg.get("ent_coef", ENT_DEFAULT[name])),
        "grad_norm": float(cfg.get("max_grad_norm", DEFAULTS["max_grad_norm"])),
        "truncate_grads": True,
    }
    if name == "apg":
        if "skip_nonfinite_updates" in cfg:
            out["skip_nonfinite_updates"] = bool(cfg["skip_nonfinite_updates"])
        return out
    out.update({
        "minibatch_size": _minibatch(int(cfg.get("batch_size", DEFAULTS["batch_size"])), batch, source),
        "mini_epochs": int(cfg.get("n_epochs", DEFAULTS["n_epochs"])),
        "minibatch_order": "shuffle",  # a fresh permutation every pass, as their iterate_minibatches
        "e_clip": float(cfg.get("clip_coef", DEFAULTS["clip_coef"])),
        "tau": float(cfg.get("gae_lambda", DEFAULTS["gae_lambda"])),
        "normalize_value": False,
        "normalize_advantage": name == "ppo",
        "clip_value": False,
        "value_bootstrap": False,
        "bounds_loss_coef": 0.0,
        "kl_threshold": 0.008,
        "kl_reference": "rollout",  # info/kl: KL to the rollout policy, as their approx_kl
    })
    if name == "ppo":
        out["critic_coef"] = 2.0 * float(cfg.get("vf_coef", DEFAULTS["vf_coef"]))
    else:
        for key in ("kl_coef", "group_size", "eps", "reset_every_rollout", "truncate_at_first_done",
                    "shared_starts"):
            if key in cfg:
                out[key] = cfg[key]
    return out


def _mlp(module: Any, path: str, source: str) -> dict[str, Any]:
    if not isinstance(module, dict):
        raise ConfigError(source, path, f"expected a mapping with type and network_cfg, got {module!r}")
    _unknown(module, MODULE_KEYS, path, source)
    if str(module.get("type", "")).lower() != "mlp":
        raise ConfigError(source, f"{path}.type", f"expected mlp, got {module.get('type')!r}")
    net = module.get("network_cfg") or {}
    _unknown(net, NETWORK_KEYS, f"{path}.network_cfg", source)
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


def _policy(policy: dict, algo: str, source: str) -> tuple[dict, dict]:
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


def _events(events: Any, enable_eval: bool, source: str) -> list[dict[str, Any]]:
    """``trainer.events.{train,eval}.<name>`` -> ``config.events`` entries (rlchain.training.env_events)."""
    if not events:
        return []
    if not isinstance(events, dict):
        raise ConfigError(source, "trainer.events", f"expected a mapping of train / eval, got {events!r}")
    _unknown(events, {"train", "eval"}, "trainer.events", source)
    out = []
    for phase, entries in events.items():
        for event, spec in (entries or {}).items():
            path = f"trainer.events.{phase}.{event}"
            if not isinstance(spec, dict) or "func" not in spec:
                raise ConfigError(source, path, "expected {func, mode, interval_step, params}")
            _unknown(spec, {"func", "mode", "interval_step", "params"}, path, source)
            mode = spec.get("mode", "interval")
            if mode != "interval":
                raise ConfigError(source, f"{path}.mode", f"{mode!r}: rlchain runs interval events")
            if phase == "eval" and not enable_eval:
                continue  # as in EmbodiChain: eval events need enable_eval
            func = str(spec["func"])
            if func in CAMERA_EVENTS:
                func = "video"
            elif ":" not in func:
                module, _, attr = func.rpartition(".")
                if not module:
                    raise ConfigError(source, f"{path}.func", f"{func!r}: name a user function package.module:"
                                                              "function (DexSim's functors other than "
                                                              f"{', '.join(CAMERA_EVENTS)} do not exist here)")
                func = f"{module}:{attr}"
            out.append({"func": func, "phase": phase, "interval_step": int(spec.get("interval_step", 1)),
                        "params": dict(spec.get("params") or {})})
    return out


def resolve_env(trainer: dict, source: str) -> tuple[str, dict[str, Any]]:
    """``trainer.learning_env`` ({name, cfg} or a name) or ``trainer.gym_config`` (a registered env name, or a
    gym_config file whose ``id`` names one) -> (rlchain env_name, env_config)."""
    if "learning_env" in trainer and "gym_config" in trainer:
        raise ConfigError(source, "trainer.learning_env", "both learning_env and gym_config given; keep one")
    if "learning_env" in trainer:
        block = trainer["learning_env"]
        name, cfg = (block, {}) if isinstance(block, str) else (block.get("name"), dict(block.get("cfg") or {}))
        return _registered(str(name), "trainer.learning_env", source, None), cfg
    if "gym_config" not in trainer:
        raise ConfigError(source, "trainer.gym_config", "required key is missing (or give trainer.learning_env)")
    value = str(trainer["gym_config"])
    if value in ENVS:
        return value, {}
    path = _find_file(value, source)
    if path is None:
        if value.endswith((".json", ".yaml", ".yml")):
            raise ConfigError(source, "trainer.gym_config", f"file {value} not found (looked in the working "
                                                            "folder and above the config); or name a registered "
                                                            f"env{did_you_mean(value, ENVS.names())}")
        return _registered(value, "trainer.gym_config", source, None), {}
    with open(path, encoding="utf-8") as fh:
        data = json.load(fh) if path.endswith(".json") else yaml.safe_load(fh)
    if not isinstance(data, dict) or "id" not in data:
        raise ConfigError(path, "id", "a gym_config file names its task under 'id'")
    return _registered(str(data["id"]), "trainer.gym_config", source, path), {}


def _find_file(value: str, source: str) -> str | None:
    """``value`` relative to the working folder, else to each folder above the config file (EmbodiChain's
    paths are relative to its repository root)."""
    if os.path.isfile(value):
        return value
    folder = os.path.dirname(os.path.abspath(source)) if source and os.path.exists(source) else None
    while folder:
        candidate = os.path.join(folder, value)
        if os.path.isfile(candidate):
            return candidate
        parent = os.path.dirname(folder)
        folder = None if parent == folder else parent
    return None


def _registered(name: str, key: str, source: str, gym_config: str | None) -> str:
    if name in ENVS:
        return name
    lower = {n.lower(): n for n in ENVS.names()}
    if name.lower() in lower:  # EmbodiChain looks names up case-insensitively
        return lower[name.lower()]
    where = f" (the id in {gym_config})" if gym_config else ""
    raise ConfigError(source, key, f"task '{name}'{where} is not a registered env: EmbodiChain's DexSim tasks "
                                   "do not install here. Register a stand-in with @rlchain.envs.backends."
                                   f"embodichain_env.register_env('{name}'), or point {key} at a registered "
                                   f"env{did_you_mean(name, ENVS.names())}")
