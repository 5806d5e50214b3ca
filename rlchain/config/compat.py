"""The only place that knows legacy rl_games keys: aliases, no-op keys and unsupported features."""

from __future__ import annotations

import warnings
from typing import Any

from rlchain.config.errors import ConfigError


class RlchainDeprecationWarning(UserWarning):
    """An rl_games key that is accepted but has no effect."""


# Keys rl_games reads (or used to) that have no effect in rlchain either: warn once and drop.
NO_EFFECT_CONFIG_KEYS = {
    "ppo": "rlchain always trains with the PPO objective",
    "load_checkpoint": "pass --checkpoint on the command line instead",
    "load_path": "pass --checkpoint on the command line instead",
    "device_name": "use `device`",
    "features": "observers are Python callbacks in rlchain",
    "use_experimental_cv": "no effect",
    "num_minibatches": "derived from minibatch_size",
    "log_interval": "rlchain logs every epoch",
    "save_frequence": "misspelt in old rl_games; use save_frequency",
    "network_path": "checkpoints go to <train_dir>/<run>/nn",
    "log_path": "logs go to <train_dir>/<run>/summaries",
    "is_train": "use --train / --play",
    "ignore_dead_batches": "rl_games 1.6.5 does not read it either",
}
NO_EFFECT_PLAYER_KEYS = {
    "device_name": "play uses config.device",
}
NO_EFFECT_PARAMS_KEYS = {
    "load_checkpoint": "pass --checkpoint on the command line instead",
    "load_path": "pass --checkpoint on the command line instead",
}
UNSUPPORTED_NETWORK_KEYS = {
    "joint_obs_actions": "joint observations/actions for the central value (SMAC)",
}
# Keys only one built-in network reads (rl_games' other builders ignore them): set elsewhere -> an error.
NETWORK_ONLY_KEYS = {
    "require_rewards": "resnet_actor_critic",
    "require_last_actions": "resnet_actor_critic",
}
NO_EFFECT_NETWORK_KEYS = {
    "regularizer": "rl_games never applied it",
}
# Keys of network.space (and of its continuous / discrete / multi_discrete blocks) that rl_games' network
# builders never read: rl_games' own examples carry them (its discrete ONNX notebook, sac_pendulum.yaml).
NO_EFFECT_SPACE_KEYS = {
    "seed": "rl_games' network builders never read it; seed with params.seed",
}
NO_EFFECT_ACTION_SPACE_KEYS = {
    "scale": "rl_games' network builders never read it (actions are rescaled with clip_actions)",
}
# central_value_config keys rl_games' central value never reads (rl_games' mjlab configs and Isaac Lab's
# asymmetric tasks carry them).
NO_EFFECT_CENTRAL_VALUE_KEYS = {
    "kl_threshold": "rl_games' central value never reads it (its learning rate is fixed or linear)",
    "schedule_type": "rl_games' central value never reads it (its learning rate is fixed or linear)",
}
# central_value_config.lr_schedule values rl_games reads as a constant learning rate (it only tests for
# 'linear'; the actor's adaptive schedule does not reach the central value's optimizer).
CONSTANT_CENTRAL_VALUE_SCHEDULES = ("adaptive",)
# Initializer blocks (mu_init, sigma_init, initializer): rl_games 2.0's const_initializer reads `value`
# beside `val`.
INITIALIZER_BLOCKS = ("mu_init", "sigma_init", "initializer")
INITIALIZER_ALIASES = {"value": "val"}
# Old spellings that mean exactly a current key.
ALIASES = {
    "seq_len": "seq_length",
    "lr_threshold": "kl_threshold",
}
# Values rl_games 2.0 names otherwise: key -> {2.0's value: rlchain's}, read silently (the same behaviour).
VALUE_ALIASES = {
    "schedule_type": {"per_minibatch": "legacy"},  # 2.0's documented default; 'legacy' is its alias there too
}
# rl_games' TensorFlow-era model names: the name brought the LSTM. In rlchain (as in rl_games' torch
# agent) the RNN is the network's `rnn` block, so each is the plain preset, read with a warning.
MODEL_ALIASES = {
    "discrete_a2c_lstm": "discrete_a2c",
    "continuous_a2c_lstm": "continuous_a2c",
    "continuous_a2c_lstm_logstd": "continuous_a2c_logstd",
}
# rl_games features with an effect that rlchain does not implement: an error, never silence.
UNSUPPORTED_CONFIG_KEYS = {
    "phasic_policy_gradients": "phasic policy gradients",
    "population_based_training": "population based training",
    "pbt": "population based training",
    "ewma_ppo": "EWMA PPO",
    "dapg": "DAPG",
    "rnd_config": "random network distillation",
    "expl_type": "exploration bonuses",
    "has_central_value": "central value via env attribute",
    "use_ppg": "phasic policy gradients",
}


OBSERVERS = {"default": "rlchain.rl_games.common.algo_observer:DefaultAlgoObserver",
             "isaac": "rlchain.rl_games.common.algo_observer:IsaacAlgoObserver"}
"""rl_games 2.0's ``config.algo_observer`` names -> the callback (rlchain.rl_games' observer) they add."""


def translate_config(config: dict[str, Any], source: str, path: str = "params.config") -> dict[str, Any]:
    """Return a copy of ``params.config`` with aliases renamed and no-op keys dropped (with a warning).

    Unsupported rl_games features raise a ConfigError naming the key.
    """
    out = dict(config)
    if "algo_observer" in out:  # rl_games 2.0: an observer by name, one of the config's callbacks here
        name = out.pop("algo_observer")
        if name not in OBSERVERS:
            raise ConfigError(source, f"{path}.algo_observer", f"expected one of {', '.join(OBSERVERS)} "
                                                               f"(rl_games 2.0's observer names), got {name!r}")
        callbacks = out.get("callbacks") or []
        out["callbacks"] = [*callbacks, OBSERVERS[name]] if isinstance(callbacks, list) else callbacks
    out = _drop_unsupported(out, UNSUPPORTED_CONFIG_KEYS, source, path)
    out = _renamed(out, ALIASES, source, path, warn=True)
    for key, values in VALUE_ALIASES.items():
        if isinstance(out.get(key), str) and out[key] in values:
            out[key] = values[out[key]]
    if "max_steps" in out:
        out = _max_steps(out, source, path)
    out = _drop_no_effect(out, NO_EFFECT_CONFIG_KEYS, source, path)
    if isinstance(out.get("player"), dict):
        out["player"] = _drop_no_effect(out["player"], NO_EFFECT_PLAYER_KEYS, source, f"{path}.player")
    cv = out.get("central_value_config")
    if isinstance(cv, dict):
        cv = _drop_no_effect(cv, NO_EFFECT_CENTRAL_VALUE_KEYS, source, f"{path}.central_value_config")
        if cv.get("lr_schedule") in CONSTANT_CENTRAL_VALUE_SCHEDULES:
            warn_once(source, f"{path}.central_value_config.lr_schedule", f"'{cv['lr_schedule']}' read as a "
                      "constant learning rate, as rl_games' central value reads it (only 'linear' changes it)")
            cv["lr_schedule"] = None
        if isinstance(cv.get("network"), dict):
            cv["network"] = translate_network(cv["network"], source, f"{path}.central_value_config.network")
        out["central_value_config"] = cv
    return out


def _max_steps(config: dict[str, Any], source: str, path: str) -> dict[str, Any]:
    """rl_games 2.0 trains to the larger of ``max_frames`` and ``max_steps`` (1.6.5 read ``max_steps`` and never
    applied it): ``max_frames`` becomes that larger value, with a warning when ``max_steps`` is the one that
    stops the run."""
    out = dict(config)
    steps = out.pop("max_steps")
    if isinstance(steps, bool) or not isinstance(steps, (int, float)):
        raise ConfigError(source, f"{path}.max_steps", f"expected a number of env frames, got {steps!r}")
    frames = out.get("max_frames", -1)
    frames = -1 if frames is None else frames
    if isinstance(frames, (int, float)) and not isinstance(frames, bool) and steps > frames:
        warn_once(source, f"{path}.max_steps", f"trains to max_steps {int(steps)} frames: rl_games 2.0 stops at "
                  f"the larger of max_frames and max_steps (1.6.5 ignored max_steps)")
        out["max_frames"] = int(steps)
    return out


ATARI_PRESETS = ("PongNoFrameskip-v4", "BreakoutNoFrameskip-v4", "MsPacmanNoFrameskip-v4")
"""rl_games' Atari preset env names: channels-last frames in 1.6.5, channels-first in 2.0."""


def translate_params(params: dict[str, Any], source: str) -> dict[str, Any]:
    """Drop rl_games' top-level no-op keys (``params.load_checkpoint`` ...) with a warning; an Atari preset
    under a CNN with ``permute_input: False`` gets channels-first frames (:func:`_atari_channels`)."""
    if isinstance(params.get("pbt"), dict):
        params = _pbt_section(params, source)
    return _atari_channels(_drop_no_effect(params, NO_EFFECT_PARAMS_KEYS, source, "params"))


def _pbt_section(params: dict[str, Any], source: str) -> dict[str, Any]:
    """rl_games 2.0's ``params.pbt`` (DexPBT, read by its PbtAlgoObserver): disabled, dropped with a warning;
    enabled, an error naming rlchain's population-based training (Ray Tune's PBT)."""
    out = dict(params)
    section = out.pop("pbt")
    if section.get("enabled"):
        raise ConfigError(source, "params.pbt.enabled", "rl_games' re-exec PBT is not offered; rlchain's "
                          "population-based training is Ray Tune's PBT: --tune SEARCH.yaml with backend: ray "
                          "(docs/tuning.md)")
    warn_once(source, "params.pbt", "accepted for rl_games compatibility, no effect: enabled is False")
    return out


def _atari_channels(params: dict[str, Any]) -> dict[str, Any]:
    """rl_games 2.0 builds its Atari presets (``env_name: PongNoFrameskip-v4`` ...) with gymnasium's frame stack,
    channels first, which its configs read with ``cnn.permute_input: False`` (1.6.5's presets are channels last,
    read with the default True). A preset with ``permute_input: False`` and no ``env_config.channels_first``
    asks rlchain's Atari env for channels-first frames, so such a 2.0 config runs as written."""
    config, network = params.get("config"), params.get("network")
    cnn = network.get("cnn") if isinstance(network, dict) else None
    if not (isinstance(config, dict) and config.get("env_name") in ATARI_PRESETS and isinstance(cnn, dict)
            and cnn.get("permute_input") is False):
        return params
    env_config = config.get("env_config") or {}
    if not isinstance(env_config, dict) or "channels_first" in env_config:
        return params
    return {**params, "config": {**config, "env_config": {**env_config, "channels_first": True}}}


def translate_model(model: Any, source: str) -> Any:
    """``params.model`` with an old rl_games model name (``discrete_a2c_lstm`` ...) replaced by its preset.

    The load checks afterwards that the network has an ``rnn`` block (:func:`check_model_alias`).
    """
    if not isinstance(model, dict) or not isinstance(model.get("name"), str) or model["name"] not in MODEL_ALIASES:
        return model
    old, new = model["name"], MODEL_ALIASES[model["name"]]
    warn_once(source, "params.model.name", f"'{old}' is an old rl_games name, read as '{new}' (the LSTM is "
              f"network.rnn)")
    return {**model, "name": new}


def check_model_alias(old_name: Any, has_rnn: bool, source: str) -> None:
    """An old ``*_lstm`` model name promises an LSTM: the network must have one."""
    if isinstance(old_name, str) and old_name in MODEL_ALIASES and not has_rnn:
        raise ConfigError(source, "params.model.name", f"'{old_name}' is rl_games' old LSTM model, but "
                          f"params.network has no rnn block; add network.rnn: {{name: lstm, units: 128}} or "
                          f"use '{MODEL_ALIASES[old_name]}'")


def translate_network(network: dict[str, Any], source: str, path: str = "params.network") -> dict[str, Any]:
    """A network block (``params.network`` or the central value's) with rl_games' old spellings read:
    the TensorFlow-era ``lstm:`` block becomes ``rnn:``; no-op keys are dropped anywhere inside."""
    out = _translate_block(_translate_tf_lstm(dict(network), source, path), source, path)
    if isinstance(out.get("space"), dict):
        out["space"] = _translate_space(out["space"], source, f"{path}.space")
    return out


def _translate_space(space: dict[str, Any], source: str, path: str) -> dict[str, Any]:
    """``network.space`` without the keys rl_games' builders never read (each a one-line warning)."""
    out = _drop_no_effect(space, NO_EFFECT_SPACE_KEYS, source, path)
    for kind in ("continuous", "discrete", "multi_discrete"):
        if isinstance(out.get(kind), dict):
            out[kind] = _drop_no_effect(out[kind], NO_EFFECT_ACTION_SPACE_KEYS, source, f"{path}.{kind}")
    return out


def _drop_unsupported(block: dict[str, Any], keys: dict[str, str], source: str, path: str) -> dict[str, Any]:
    """``block`` without ``keys`` (rl_games features rlchain lacks) left off; one switched on is a ConfigError."""
    out = dict(block)
    for key, reason in keys.items():
        if key in out and out[key] not in (None, False, {}):
            raise ConfigError(source, f"{path}.{key}",
                              f"rl_games feature '{reason}' is not implemented in rlchain; remove the key")
        out.pop(key, None)
    return out


def _drop_no_effect(block: dict[str, Any], keys: dict[str, str], source: str, path: str) -> dict[str, Any]:
    out = dict(block)
    for key, reason in keys.items():
        if key in out:
            warn_once(source, f"{path}.{key}", f"accepted for rl_games compatibility, no effect: {reason}")
            out.pop(key)
    return out


def _renamed(block: dict[str, Any], aliases: dict[str, str], source: str, path: str, warn: bool) -> dict[str, Any]:
    """``block`` with each old name of ``aliases`` read as its new one (a one-line warning with ``warn``); both
    given is an error."""
    out = dict(block)
    for old, new in aliases.items():
        if old in out:
            if new in out:
                raise ConfigError(source, f"{path}.{old}", f"both '{old}' and '{new}' given; keep only '{new}'")
            if warn:
                warn_once(source, f"{path}.{old}", f"deprecated name, use '{new}'")
            out[new] = out.pop(old)
    return out


def _translate_tf_lstm(out: dict[str, Any], source: str, path: str) -> dict[str, Any]:
    """``lstm: {units: N, concated: False}`` (rl_games' TensorFlow agent) -> ``rnn: {name: lstm, units: N}``.

    There it was one LSTM layer after the MLP, one per trunk with ``separate``; ``concated: True``
    with ``separate`` ran a single LSTM over both trunks' outputs, which rlchain does not have.
    """
    if "lstm" not in out:
        return out
    where, lstm = f"{path}.lstm", out.pop("lstm")
    if "rnn" in out:
        raise ConfigError(source, where, "both 'lstm' (old rl_games spelling) and 'rnn' given; keep only 'rnn'")
    if not isinstance(lstm, dict) or "units" not in lstm:
        raise ConfigError(source, where, f"expected {{units: N, concated: False}} (old rl_games spelling of "
                          f"rnn: {{name: lstm, units: N}}), got {lstm!r}")
    unknown = sorted(set(lstm) - {"units", "concated"})
    if unknown:
        raise ConfigError(source, f"{where}.{unknown[0]}", "unknown key; the old lstm block has units and "
                          "concated (use an rnn block for more)")
    if lstm.get("concated") and str(out.get("separate")).lower() == "true":
        raise ConfigError(source, f"{where}.concated", "rl_games feature 'one LSTM over both separate trunks' "
                          "is not implemented in rlchain; remove the key or set it to False")
    warn_once(source, where, f"old rl_games (TensorFlow) spelling, read as rnn: {{name: lstm, units: "
              f"{lstm['units']}}}")
    out["rnn"] = {"name": "lstm", "units": lstm["units"]}
    return out


def _translate_block(network: dict[str, Any], source: str, path: str) -> dict[str, Any]:
    """Drop no-op keys anywhere in the network block (rl_games allows ``regularizer`` in several places)."""
    out = _drop_unsupported(network, UNSUPPORTED_NETWORK_KEYS, source, path)
    for key, owner in NETWORK_ONLY_KEYS.items():
        if key in out and out.get("name", "actor_critic") != owner:
            if out[key] not in (None, False, {}):
                raise ConfigError(source, f"{path}.{key}", f"only network {owner} reads it (the previous reward "
                                                           f"/ action as an input); this network is "
                                                           f"'{out.get('name', 'actor_critic')}'")
            out.pop(key)
    out = _drop_no_effect(out, NO_EFFECT_NETWORK_KEYS, source, path)
    for key, value in list(out.items()):
        if isinstance(value, dict):
            if key in INITIALIZER_BLOCKS:  # rl_games 2.0's const_initializer reads `value` beside `val`
                value = _renamed(value, INITIALIZER_ALIASES, source, f"{path}.{key}", warn=False)
            out[key] = _translate_block(value, source, f"{path}.{key}")
    return out


_warned: set[str] = set()


def warn_once(source: str, path: str, message: str) -> None:
    """A one-line ``RlchainDeprecationWarning`` naming file and key, given once per process."""
    line = f"{source}: {path}: {message}"
    if line not in _warned:
        _warned.add(line)
        warnings.warn(line, RlchainDeprecationWarning, stacklevel=3)
