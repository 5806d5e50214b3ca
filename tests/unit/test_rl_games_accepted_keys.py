"""Keys rl_games accepts: rl_games 2.0's ``sigma_init.value``, and keys its builders never read (a warning
naming the key); a key rl_games knows nowhere stays an error with a did-you-mean."""

import copy
import warnings

import pytest

from rlchain.config import ConfigError
from rlchain.config.compat import RlchainDeprecationWarning
from rlchain.config.load import parse_params

CONTINUOUS = {
    "params": {
        "seed": 1,
        "algo": {"name": "a2c_continuous"},
        "model": {"name": "continuous_a2c_logstd"},
        "network": {"name": "actor_critic", "separate": False, "mlp": {"units": [8]},
                    "space": {"continuous": {"mu_activation": "None", "sigma_activation": "None",
                                             "mu_init": {"name": "default"},
                                             "sigma_init": {"name": "const_initializer", "val": 0},
                                             "fixed_sigma": True}}},
        "config": {"name": "t", "env_name": "Pendulum-v1", "device": "cpu", "num_actors": 2,
                   "horizon_length": 8, "minibatch_size": 16, "mini_epochs": 1},
    }
}


def _parse(cfg, source):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        params = parse_params(cfg, source)
    return params, [str(w.message) for w in caught if issubclass(w.category, RlchainDeprecationWarning)]


def test_sigma_init_value_is_read_as_val():
    cfg = copy.deepcopy(CONTINUOUS)
    cfg["params"]["network"]["space"]["continuous"]["sigma_init"] = {"name": "const_initializer", "value": -1.5}
    params, _ = _parse(cfg, "value.yaml")
    assert params.network.space.continuous.sigma_init.val == -1.5
    cfg["params"]["network"]["space"]["continuous"]["sigma_init"]["val"] = 0
    with pytest.raises(ConfigError, match="sigma_init.value: both 'value' and 'val'"):
        parse_params(cfg, "both.yaml")


def test_keys_rl_games_never_reads_are_one_line_warnings():
    cfg = copy.deepcopy(CONTINUOUS)
    cfg["params"]["network"]["space"]["continuous"]["scale"] = 1.0
    cfg["params"]["network"]["space"]["seed"] = 5
    _, messages = _parse(cfg, "ignored.yaml")
    assert any("ignored.yaml: params.network.space.continuous.scale: accepted" in m for m in messages)
    assert any("ignored.yaml: params.network.space.seed: accepted" in m for m in messages)
    assert all("\n" not in m for m in messages)


def test_an_unknown_key_is_still_an_error_with_a_did_you_mean():
    cfg = copy.deepcopy(CONTINUOUS)
    cfg["params"]["network"]["space"]["continuous"]["fixed_sigmaa"] = True
    with pytest.raises(ConfigError, match="did you mean 'fixed_sigma'"):
        parse_params(cfg, "typo.yaml")


def test_central_value_kl_threshold_is_a_warning():
    cfg = copy.deepcopy(CONTINUOUS)
    cfg["params"]["config"]["central_value_config"] = {"kl_threshold": 0.01, "learning_rate": 1e-3,
                                                       "mini_epochs": 1, "minibatch_size": 16,
                                                       "network": {"name": "actor_critic", "mlp": {"units": [8]}}}
    params, messages = _parse(cfg, "cv.yaml")
    assert params.config.central_value_config is not None
    assert any("params.config.central_value_config.kl_threshold: accepted" in m for m in messages)


def test_central_value_schedule_keys_of_isaac_labs_asymmetric_tasks():
    """schedule_type is never read there; lr_schedule 'adaptive' is a constant rate in rl_games' central value."""
    cfg = copy.deepcopy(CONTINUOUS)
    cfg["params"]["config"]["central_value_config"] = {"schedule_type": "standard", "lr_schedule": "adaptive",
                                                       "learning_rate": 1e-3, "mini_epochs": 1, "minibatch_size": 16,
                                                       "network": {"name": "actor_critic", "mlp": {"units": [8]}}}
    params, messages = _parse(cfg, "cv.yaml")
    assert params.config.central_value_config.lr_schedule is None
    assert any("central_value_config.schedule_type: accepted" in m for m in messages)
    assert any("central_value_config.lr_schedule: 'adaptive' read as a constant" in m for m in messages)
    cfg["params"]["config"]["central_value_config"]["lr_schedule"] = "cosine"
    with pytest.raises(ConfigError, match="lr_schedule"):
        parse_params(cfg, "cv.yaml")
