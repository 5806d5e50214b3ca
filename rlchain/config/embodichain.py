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

The keys and defaults are in :mod:`~rlchain.config.embodichain_keys`, the policy block's translation in
:mod:`~rlchain.config.embodichain_policy`, the task's in :mod:`~rlchain.config.embodichain_task`.
"""

from __future__ import annotations

import inspect
import math
import os
from typing import Any

from rlchain.config.compat import warn_once
from rlchain.config.embodichain_keys import (
    ALGO_CFG,
    ALGORITHM_KEYS,
    CAMERA_EVENTS,
    DEFAULTS,
    ENT_DEFAULT,
    LEARNING_ENV_DEFAULTS,
    POLICY_KEYS,
    RLCHAIN_ALGO,
    SIM_ONLY_KEYS,
    TOP_KEYS,
    TRAINER_KEYS,
    reject_unknown,
)
from rlchain.config.embodichain_policy import policy_blocks
from rlchain.config.embodichain_task import resolve_env
from rlchain.config.errors import ConfigError
from rlchain.errors import did_you_mean
from rlchain.registry import ENVS


def is_embodichain(raw: Any) -> bool:
    """Whether a config dict is in EmbodiChain's layout (a ``trainer`` block, no ``params``)."""
    return isinstance(raw, dict) and "params" not in raw and "trainer" in raw


def split_overrides(overrides: list[str]) -> tuple[list[str], list[str]]:
    """Overrides on EmbodiChain's keys (``trainer.*``, ``policy.*``, ``algorithm.*``) and the rest (rlchain's
    ``params.*``, applied after the translation)."""
    ours = [o for o in overrides if o.split("=", 1)[0].split(".")[0] in TOP_KEYS]
    return ours, [o for o in overrides if o not in ours]


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
    reject_unknown(trainer, TRAINER_KEYS, "trainer", source)
    reject_unknown(policy, POLICY_KEYS, "policy", source)
    reject_unknown(algorithm, ALGORITHM_KEYS, "algorithm", source)
    name = str(algorithm.get("name", "")).lower()
    if name not in ALGO_CFG:
        raise ConfigError(source, "algorithm.name", f"expected one of {', '.join(ALGO_CFG)}, got "
                                                    f"{algorithm.get('name')!r}{did_you_mean(name, ALGO_CFG)}")
    cfg = algorithm.get("cfg") or {}
    if not isinstance(cfg, dict):
        raise ConfigError(source, "algorithm.cfg", f"expected a mapping, got {cfg!r}")
    reject_unknown(cfg, ALGO_CFG[name], "algorithm.cfg", source)
    for key in SIM_ONLY_KEYS:
        if key in trainer:
            warn_once(source, f"trainer.{key}", "a DexSim simulator setting; no effect on rlchain's envs")

    defaults = {**DEFAULTS, **(LEARNING_ENV_DEFAULTS if "learning_env" in trainer else {})}
    env_name, env_config = resolve_env(trainer, source)
    builder = ENVS.get(env_name).get("vecenv_creator")
    if "device" not in env_config and builder is not None and "device" in inspect.signature(builder).parameters:
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
    model, network = policy_blocks(policy, name, source)
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
    reject_unknown(optimizer, {"name", "learning_rate", "kwargs"}, "algorithm.cfg.optimizer", source)
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


def _events(events: Any, enable_eval: bool, source: str) -> list[dict[str, Any]]:
    """``trainer.events.{train,eval}.<name>`` -> ``config.events`` entries (rlchain.training.env_events)."""
    if not events:
        return []
    if not isinstance(events, dict):
        raise ConfigError(source, "trainer.events", f"expected a mapping of train / eval, got {events!r}")
    reject_unknown(events, {"train", "eval"}, "trainer.events", source)
    out = []
    for phase, entries in events.items():
        for event, spec in (entries or {}).items():
            path = f"trainer.events.{phase}.{event}"
            if not isinstance(spec, dict) or "func" not in spec:
                raise ConfigError(source, path, "expected {func, mode, interval_step, params}")
            reject_unknown(spec, {"func", "mode", "interval_step", "params"}, path, source)
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


