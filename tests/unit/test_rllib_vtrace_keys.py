"""PPO's RLlib-only options on the face's APPO / IMPALA: the translation sets none, and an rlchain appo / impala
config that sets RLlib's advantage standardization is refused in one line when it is loaded (it needs PPO's
rollout, and used to fail only at the first update)."""

import gymnasium as gym
import pytest

from rlchain.config.errors import ConfigError
from rlchain.config.load import parse_params
from rlchain.rllib.algorithms.appo import APPOConfig
from rlchain.rllib.algorithms.impala import IMPALAConfig
from rlchain.rllib.algorithms.impala.translate import vtrace_config

RUN = {"name": "t", "device": "cpu", "print_stats": False}


def _translated(config_class):
    config = config_class().environment("CartPole-v1").env_runners(num_env_runners=1)
    return vtrace_config(config, "CartPole-v1", gym.spaces.Box(-1, 1, (4,)), False, RUN)


@pytest.mark.parametrize("config_class", [APPOConfig, IMPALAConfig])
def test_translation_sets_no_ppo_only_standardization(config_class):
    out = _translated(config_class)
    cfg = out["params"]["config"]
    assert cfg["normalize_advantage"] is False  # RLlib's APPO / IMPALA standardize nothing
    assert cfg.get("advantage_normalization", "batch") != "rllib" and cfg.get("minibatch_order") != "rllib"
    parse_params(out, "face")  # loads as it is


@pytest.mark.parametrize("config_class", [APPOConfig, IMPALAConfig])
def test_rllib_standardization_is_refused_at_load(config_class):
    out = _translated(config_class)
    out["params"]["config"].update(normalize_advantage=True, advantage_normalization="rllib")
    with pytest.raises(ConfigError, match="params.config.advantage_normalization: rllib is PPO's") as err:
        parse_params(out, "face")
    assert "\n" not in str(err.value)
    out["params"]["config"]["normalize_advantage"] = False  # switched off: nothing to refuse
    parse_params(out, "face")
