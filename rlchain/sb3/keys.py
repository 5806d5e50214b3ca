"""Stable-Baselines3's constructor arguments -> an rl_games-style rlchain config (plain data, no torch).

:func:`build_config` starts from rlchain's settings for the family (those of the packaged examples
``ppo_cartpole`` / ``ppo_pendulum``, ``sac_pendulum``, ``dqn_cartpole``), then applies each argument the
user gave: an SB3 name (``n_steps``, ``gae_lambda``, ``buffer_size``, ...) through its mapping, or an
rlchain config key (``horizon_length``, ``kl_threshold``, ...) as it is. Anything else is a one-line
:class:`~rlchain.config.errors.ConfigError` with a did-you-mean.
"""

from __future__ import annotations

import copy
import functools
import numbers
import re
from collections.abc import Iterable
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.packaged import config_names
from rlchain.config.text import read_data
from rlchain.errors import did_you_mean
from rlchain.sb3.defaults import CHOICES, SB3_DEFAULTS, SB3_EXPLORATION_FRACTION, SB3_TRAIN_FREQ
from rlchain.sb3.her import her_config

SOURCE = "rlchain.{algo}"  # where ConfigErrors say the bad argument came from

ACTIVATIONS = {"tanh": "tanh", "relu": "relu", "elu": "elu", "selu": "selu", "silu": "swish", "swish": "swish",
               "gelu": "gelu", "softplus": "softplus", "sigmoid": "sigmoid", "identity": "None"}
"""torch.nn activation class names (lower case) -> rl_games' activation names."""

PACKAGED = {"ppo": "ppo_cartpole", "ppo_continuous": "ppo_pendulum", "sac": "sac_pendulum", "dqn": "dqn_cartpole"}
"""Family -> the packaged example (``rlchain/configs/<name>.yaml``) whose settings ``defaults="rlchain"`` takes."""

EXAMPLE_KEYS = ("name", "env_name", "device", "num_actors", "horizon_length", "max_epochs", "max_frames",
                "score_to_win", "games_to_track", "player")
"""``params.config`` keys of a packaged example that belong to its env and run, not to the family's settings:
the SB3 face sets them from its own arguments (or leaves them at rlchain's defaults)."""

_YAML_FLOAT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")  # YAML 1.1 reads 1e-3 as a string


def _numbers(value: Any) -> Any:
    """``value`` with YAML 1.1's exponent strings (``3e-4``) as floats, nested blocks included."""
    if isinstance(value, dict):
        return {k: _numbers(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_numbers(v) for v in value]
    return float(value) if isinstance(value, str) and _YAML_FLOAT.fullmatch(value) else value


@functools.cache
def _example(family: str) -> dict[str, Any]:
    """The ``params`` of the packaged example of ``family`` (see :data:`PACKAGED`), read once."""
    return _numbers(read_data(config_names()[PACKAGED[family]])["params"])


def packaged_defaults(family: str) -> dict[str, Any]:
    """``{'network': ..., 'config': ...}``: the settings of ``family``'s packaged example without the keys of
    its env and run (:data:`EXAMPLE_KEYS`); a fresh copy."""
    params = copy.deepcopy(_example(family))
    config = {k: v for k, v in params["config"].items() if k not in EXAMPLE_KEYS}
    return {"network": params["network"], "config": config}


def rlchain_num_envs(algo: str) -> int:
    """Envs stepped together with ``defaults="rlchain"`` when the env argument does not fix the count and
    ``n_envs`` is not given: the ``num_actors`` of the algo's packaged example."""
    return int(_example(algo)["config"]["num_actors"])


def _ppo_frames_per_epoch() -> int:
    """The frames of one PPO epoch of the packaged example; the default horizon_length is this / num_actors
    (at least 16)."""
    config = _example("ppo")["config"]
    return int(config["num_actors"]) * int(config["horizon_length"])


ALGO_NAMES = {"ppo": ("a2c_discrete", "discrete_a2c"), "ppo_continuous": ("a2c_continuous", "continuous_a2c_logstd"),
              "sac": ("sac", "soft_actor_critic"), "dqn": ("dqn", "dqn")}


class Unsupported(str):
    """A known SB3 argument with no rlchain counterpart: the string says what to use instead."""


def _lr_all(value: Any) -> dict[str, Any]:
    lr = _number("learning_rate", value)
    return {"actor_lr": lr, "critic_lr": lr, "alpha_lr": lr}


def _number(name: str, value: Any) -> float:
    if callable(value) or isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    return float(value)


def _whole(name: str, key: str) -> Any:
    """The mapping of an SB3 argument that is a positive int, to the rlchain key ``key``."""
    def mapping(value: Any) -> dict[str, int]:
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f"{name}: expected an int >= 1, got {value!r}")
        return {key: value}
    return mapping


def _train_freq(value: Any) -> int:
    if isinstance(value, (tuple, list)):
        if len(value) != 2 or str(value[1]) != "step":
            raise ValueError(f"train_freq: {value!r}: only (n, 'step') maps to rlchain (it updates after env steps)")
        value = value[0]
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"train_freq: expected an int >= 1, got {value!r}")
    return value


def _ent_coef(value: Any) -> dict[str, Any]:
    if isinstance(value, str) and (value == "auto" or value.startswith("auto_")):
        return {"learnable_temperature": True, "init_alpha": float(value[5:]) if value != "auto" else 1.0}
    return {"learnable_temperature": False, "init_alpha": _number("ent_coef", value)}


def _every_step(value: Any) -> dict[str, Any]:
    if value != 1:
        raise ValueError("target_update_interval: rlchain's SAC updates its targets after every update (Polyak, "
                         "tau); only 1 maps")
    return {}


def _clip_range_vf(value: Any) -> dict[str, Any]:
    return {"clip_value": value is not None}


PPO_KEYS: dict[str, Any] = {
    "learning_rate": lambda v: {"learning_rate": _number("learning_rate", v), "lr_schedule": None},
    "n_steps": _whole("n_steps", "horizon_length"), "batch_size": _whole("batch_size", "minibatch_size"),
    "n_epochs": _whole("n_epochs", "mini_epochs"), "gamma": "gamma",
    "gae_lambda": "tau", "clip_range": lambda v: {"e_clip": _number("clip_range", v)},
    "clip_range_vf": _clip_range_vf, "normalize_advantage": "normalize_advantage", "ent_coef": "entropy_coef",
    "vf_coef": lambda v: {"critic_coef": 2 * _number("vf_coef", v)},  # rlchain's value loss is 0.5 * coef * mse
    "max_grad_norm": lambda v: {"grad_norm": _number("max_grad_norm", v), "truncate_grads": True},
    "stats_window_size": "games_to_track",
    "target_kl": Unsupported("rlchain adapts the learning rate to a KL target instead: "
                             "lr_schedule='adaptive', kl_threshold=..."),
    "use_sde": Unsupported("state-dependent exploration is not in rlchain"),
    "sde_sample_freq": Unsupported("state-dependent exploration is not in rlchain"),
    "rollout_buffer_class": Unsupported("rlchain's rollout storage is built in"),
    "rollout_buffer_kwargs": Unsupported("rlchain's rollout storage is built in"),
}

OFF_POLICY_KEYS: dict[str, Any] = {
    "buffer_size": "replay_buffer_size", "learning_starts": "num_warmup_frames", "batch_size": "batch_size",
    "gamma": "gamma", "stats_window_size": "games_to_track",
    "train_freq": None, "gradient_steps": None,  # together: num_updates_per_step, update_every (_updates)
    "action_noise": Unsupported("rlchain's SAC explores with its own policy noise"),
    "replay_buffer_class": None, "replay_buffer_kwargs": None,  # together: config.replay (sb3/her.py)
    "optimize_memory_usage": Unsupported("rlchain's replay buffer is built in"),
}

SAC_KEYS: dict[str, Any] = {
    **OFF_POLICY_KEYS, "learning_rate": _lr_all, "tau": "critic_tau", "ent_coef": _ent_coef,
    "target_entropy": lambda v: {"target_entropy": None if v == "auto" else _number("target_entropy", v)},
    "target_update_interval": lambda v: _every_step(v),
    "use_sde": Unsupported("state-dependent exploration is not in rlchain"),
    "sde_sample_freq": Unsupported("state-dependent exploration is not in rlchain"),
    "use_sde_at_warmup": Unsupported("state-dependent exploration is not in rlchain"),
}

DQN_KEYS: dict[str, Any] = {
    **OFF_POLICY_KEYS, "learning_rate": lambda v: {"learning_rate": _number("learning_rate", v)},
    "tau": "target_tau", "target_update_interval": "target_update_frequency",
    "exploration_initial_eps": "epsilon_start", "exploration_final_eps": "epsilon_end",
    "exploration_fraction": None,  # * total_timesteps: epsilon_decay_frames (see build_config)
    "max_grad_norm": "grad_norm",
}

KEYS = {"ppo": PPO_KEYS, "sac": SAC_KEYS, "dqn": DQN_KEYS}

POLICY_KWARGS = ("net_arch", "activation_fn", "log_std_init", "clip_mean")


def _updates(algo: str, given: dict[str, Any], num_actors: int) -> dict[str, Any]:
    """SB3's train_freq / gradient_steps: ``gradient_steps`` updates after every ``train_freq`` steps of each env
    (rlchain's ``num_updates_per_step`` every ``update_every`` vectorized steps); -1 = as many updates as env
    steps collected since the last round. The train_freq not given is SB3's default for ``algo`` (DQN 4)."""
    if "train_freq" not in given and "gradient_steps" not in given:
        return {}
    freq = _train_freq(given.get("train_freq", SB3_TRAIN_FREQ.get(algo, 1)))
    steps = given.get("gradient_steps", 1)
    if isinstance(steps, bool) or not isinstance(steps, int) or steps == 0 or steps < -1:
        raise ValueError(f"gradient_steps: expected an int >= 1 or -1, got {steps!r}")
    steps = freq * num_actors if steps == -1 else steps
    return {"num_updates_per_step": steps, "update_every": freq}


def _net_arch(algo: str, value: Any) -> dict[str, Any]:
    critic = None
    if isinstance(value, dict):
        other = "vf" if algo == "ppo" else "qf"
        unknown = set(value) - {"pi", other}
        if unknown:
            raise ValueError(f"policy_kwargs.net_arch: {value!r}: expected the keys pi and {other}")
        pi, critic = list(value.get("pi", [])), list(value.get(other, []))
        if pi != critic and algo != "ppo":  # SAC's separate sizes build the sb3_policy network (policy_block.py)
            raise ValueError(f"policy_kwargs.net_arch: {value!r}: {algo.upper()}'s network takes one list")
        value, critic = pi, (critic if critic != pi else None)
    if not isinstance(value, (list, tuple)) or not all(isinstance(u, int) and u > 0 for u in value):
        raise ValueError(f"policy_kwargs.net_arch: expected a list of layer sizes, got {value!r}")
    network: dict[str, Any] = {"mlp": {"units": list(value)}}
    if algo == "ppo":
        network["separate"] = True  # SB3's actor and critic share no layers
    if critic is not None:  # the critic's own sizes (its activation: the actor's, set in build_config)
        network["critic_mlp"] = {"units": critic}
    return network


def activation_name(value: Any) -> str:
    """rl_games' name of a torch.nn activation class (``nn.ReLU``) or name (``'relu'``)."""
    name = value if isinstance(value, str) else getattr(value, "__name__", repr(value))
    found = ACTIVATIONS.get(str(name).lower())
    if found is None:
        raise ValueError(f"policy_kwargs.activation_fn: {name} has no rl_games activation "
                         f"(choices: {', '.join(sorted(ACTIVATIONS))})")
    return found


def _policy_kwargs(algo: str, continuous: bool, policy_kwargs: dict[str, Any]) -> dict[str, Any]:
    network: dict[str, Any] = {}
    for key, value in policy_kwargs.items():
        if key == "net_arch":
            _merge(network, _net_arch(algo, value))
        elif key == "activation_fn":
            _merge(network, {"mlp": {"activation": activation_name(value)}})
        elif key == "log_std_init" and algo == "ppo":  # as in SB3, no effect on discrete actions
            if continuous:
                _merge(network, {"space": {"continuous": {"sigma_init": {"name": "const_initializer",
                                                                         "val": _number(key, value)}}}})
        elif key == "clip_mean" and algo == "sac":  # SB3 clips the gSDE actor's mean; here the mean of any SAC
            if isinstance(value, bool) or not isinstance(value, (int, float)) or value < 0:
                raise ValueError(f"policy_kwargs.clip_mean: expected a number >= 0 (0: no clip), got {value!r}")
            _merge(network, {"mean_clip": float(value) if value > 0 else None})
        else:
            raise ValueError(f"policy_kwargs: unknown key '{key}'{did_you_mean(key, POLICY_KWARGS)} "
                             f"(rlchain maps {', '.join(POLICY_KWARGS)}; any network block: network=...)")
    return network


def _merge(into: dict[str, Any], new: dict[str, Any]) -> None:
    for key, value in new.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            _merge(into[key], value)
        else:
            into[key] = copy.deepcopy(value)


def run_name(algo: str, env_name: str) -> str:
    """A run name from the algorithm and the env: ``ppo_cartpole``."""
    env = re.sub(r"-v\d+$", "", env_name.rsplit("/", 1)[-1])
    return f"{algo}_{re.sub(r'[^a-z0-9]+', '_', env.lower()).strip('_') or 'env'}"


def build_config(algo: str, env_name: str, num_actors: int, continuous: bool, given: dict[str, Any],
                 rlchain_keys: Iterable[str], policy_kwargs: dict[str, Any] | None = None,
                 total_timesteps: int | None = None, seed: int | None = None,
                 run: dict[str, Any] | None = None, defaults: str = "sb3") -> dict[str, Any]:
    """The ``{'params': ...}`` config of ``algo`` (ppo, sac, dqn) on ``env_name`` with ``num_actors`` envs,
    after the user's arguments ``given`` (SB3 names, or the rlchain config keys ``rlchain_keys``).
    ``defaults``: what arguments left out take, ``sb3`` (SB3's own: :mod:`rlchain.sb3.defaults`) or ``rlchain``
    (the packaged examples': :func:`packaged_defaults`). ``run``: further ``params.config`` keys (train_dir, device,
    print_stats, ...). ValueError (a ConfigError naming the argument) for an unknown or unmappable argument."""
    source = SOURCE.format(algo=algo.upper())
    if defaults not in CHOICES:
        raise ConfigError(source, "defaults", f"expected one of {', '.join(CHOICES)}, got {defaults!r}")
    family = "ppo_continuous" if algo == "ppo" and continuous else algo
    if defaults == "rlchain":
        network, config = packaged_defaults(family).values()
    else:
        network = copy.deepcopy(SB3_DEFAULTS[algo]["network"])
        config = copy.deepcopy(SB3_DEFAULTS[algo]["config"])
        if family != algo:
            _merge(network, SB3_DEFAULTS[family]["network"])
            _merge(config, SB3_DEFAULTS[family]["config"])
        elif algo == "ppo":
            network["space"] = {"discrete": None}
    config.update({"name": run_name(algo, env_name), "env_name": env_name, "num_actors": num_actors})
    table, rlchain_keys = KEYS[algo], set(rlchain_keys)
    try:
        for key, value in given.items():
            mapping = table.get(key, key if key in rlchain_keys else ...)
            if mapping is ...:
                raise ConfigError(source, key, f"unknown argument{did_you_mean(key, [*table, *rlchain_keys])} "
                                               f"(an SB3 argument or an rlchain config key: docs/sb3.md)")
            if isinstance(mapping, Unsupported):
                raise ConfigError(source, key, f"has no rlchain counterpart: {mapping}")
            if mapping is None:
                continue  # read together with other arguments below
            config.update(mapping(value) if callable(mapping) else {mapping: value})
        config.update(_updates(algo, given, num_actors))
        if algo != "ppo":
            replay = her_config(given.get("replay_buffer_class"), given.get("replay_buffer_kwargs"))
            if replay:
                config["replay"] = replay
        if algo == "dqn" and ("exploration_fraction" in given or defaults == "sb3"):
            fraction = _number("exploration_fraction", given.get("exploration_fraction", SB3_EXPLORATION_FRACTION))
            if total_timesteps is not None:
                config["epsilon_decay_frames"] = max(1, int(fraction * total_timesteps))
        _merge(network, _policy_kwargs(algo, continuous, dict(policy_kwargs or {})))
        if "critic_mlp" in network:  # the critic's MLP as the actor's but for its sizes
            network["critic_mlp"] = {**copy.deepcopy(network["mlp"]), "units": network["critic_mlp"]["units"]}
    except ConfigError:
        raise
    except ValueError as exc:
        key, _, message = str(exc).partition(": ")
        raise ConfigError(source, key, message) from None
    if algo == "ppo":
        if config.get("horizon_length") is None:
            config["horizon_length"] = max(16, -(-_ppo_frames_per_epoch() // num_actors))
        if "minibatch_size" not in given:  # the largest that divides the batch, as rlchain requires
            batch = num_actors * config["horizon_length"]
            config["minibatch_size"] = max(d for d in range(1, min(config["minibatch_size"], batch) + 1)
                                           if batch % d == 0)
    if total_timesteps is not None:
        config["max_frames"] = int(total_timesteps)
    config.update(run or {})
    name, model = ALGO_NAMES[family]
    params: dict[str, Any] = {"algo": {"name": name}, "model": {"name": model}, "network": network, "config": config}
    if seed is not None:
        params["seed"] = int(seed)
    return {"params": params}


def multi_input_block(algo: str, params: dict[str, Any], name: str) -> None:
    """``params``' network renamed ``name`` (MultiInputPolicy's multi_input), in place; SAC's log-std bounds move
    to ``config.log_std_bounds`` (the same bounds; multi_input has no such network key). SB3's ``clip_mean``
    (a gSDE actor) has no multi_input counterpart: a ConfigError naming it."""
    network, config = params["network"], params["config"]
    network["name"] = name
    if algo == "sac":
        bounds = network.pop("log_std_bounds", None)
        if bounds is not None:
            config.setdefault("log_std_bounds", bounds)
        if network.pop("mean_clip", None) is not None:
            raise ConfigError(SOURCE.format(algo=algo.upper()), "policy_kwargs.clip_mean",
                              "not supported with MultiInputPolicy (a gSDE actor); remove it")


def positive_count(source: str, name: str, value: Any) -> int:
    """``value`` as a positive whole number of frames, else a one-line ConfigError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or value < 1 or int(value) != value:
        raise ConfigError(source, name, f"expected a positive whole number of env steps, got {value!r}")
    return int(value)
