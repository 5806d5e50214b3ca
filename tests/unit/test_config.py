"""Config parsing: defaults, rl_games quirks and one-line errors for bad input."""

import json
import warnings

import pytest

from rlchain.config import ConfigError, compat, load_config, parse_params
from rlchain.config.compat import RlchainDeprecationWarning
from rlchain.config.load import apply_overrides
from rlchain.config.network import NetworkConfig


def parse(cfg):
    return parse_params(cfg, "cfg.yaml")


def test_defaults_and_types(base_config):
    params = parse(base_config)
    assert params.config.gamma == 0.99
    assert params.config.minibatch_size == 16
    assert isinstance(params.network, NetworkConfig)
    assert params.network.space.discrete is not None and params.network.space.continuous is None


def test_yaml11_float_strings_and_none_strings(base_config):
    base_config["params"]["config"]["learning_rate"] = "2e-4"
    base_config["params"]["config"]["lr_schedule"] = "None"
    params = parse(base_config)
    assert params.config.learning_rate == pytest.approx(2e-4)
    assert params.config.lr_schedule is None


def test_unknown_key_suggests(base_config):
    base_config["params"]["config"]["learning_rat"] = 1e-3
    with pytest.raises(ConfigError) as err:
        parse(base_config)
    msg = str(err.value)
    assert msg.startswith("cfg.yaml: params.config.learning_rat: unknown key")
    assert "did you mean 'learning_rate'" in msg
    assert "\n" not in msg


@pytest.mark.parametrize("key,value,expect", [
    ("learning_rate", -1.0, "must be > 0"),
    ("learning_rate", "fast", "expected a number"),
    ("num_actors", 2.5, "expected an integer"),
    ("normalize_input", "maybe", "expected true or false"),
    ("lr_schedule", "adaptve", "did you mean 'adaptive'"),
    ("gamma", 1.5, "between 0 and 1"),
    ("success_to_win", 90, "must be between 0 and 1 (a fraction of episodes), or inf"),
    ("timeout_bootstrap", "last_value", "'last_value' is not one of: final_obs, previous_value"),
    ("obs_normalizer_update", "batch", "'batch' is not one of: auto, rollout, minibatch"),
    ("log_info_keys", "reward_box_target", "expected a list, got 'reward_box_target'"),
    # minibatch_size against the batch is checked with the env (its agent count): test_minibatch_checked_with_env
])
def test_bad_values(base_config, key, value, expect):
    base_config["params"]["config"][key] = value
    with pytest.raises(ConfigError) as err:
        parse(base_config)
    assert f"params.config.{key}" in str(err.value)
    assert expect in str(err.value)


def test_unknown_activation(base_config):
    base_config["params"]["network"]["mlp"]["activation"] = "rleu"
    with pytest.raises(ConfigError, match=r"params.network.mlp.activation: 'rleu' is not one of.*'relu'"):
        parse(base_config)


def test_unknown_algo_and_network(base_config):
    base_config["params"]["algo"]["name"] = "a2c_discrte"
    with pytest.raises(ConfigError, match=r"params.algo.name: unknown algo 'a2c_discrte'; did you mean"):
        parse(base_config)
    base_config["params"]["algo"]["name"] = "a2c_discrete"
    base_config["params"]["network"]["name"] = "nope"
    with pytest.raises(ConfigError, match=r"params.network.name: unknown network"):
        parse(base_config)


def test_minibatch_size_per_env(base_config):
    del base_config["params"]["config"]["minibatch_size"]
    base_config["params"]["config"]["minibatch_size_per_env"] = 2
    assert parse(base_config).config.minibatch_size == 8


def test_deprecated_keys_warn_once(base_config):
    base_config["params"]["config"]["ppo"] = True
    base_config["params"]["config"]["load_checkpoint"] = False
    base_config["params"]["network"]["mlp"]["regularizer"] = {"name": "None"}
    base_config["params"]["config"]["seq_len"] = 8
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        params = parse(base_config)
    texts = [str(w.message) for w in caught if issubclass(w.category, RlchainDeprecationWarning)]
    assert any("params.config.ppo" in t for t in texts)
    assert any("params.network.mlp.regularizer" in t for t in texts)
    assert params.config.seq_length == 8


def test_unimplemented_feature_is_an_error(base_config):
    base_config["params"]["config"]["epochs_between_resets"] = 5
    with pytest.raises(ConfigError, match=r"params.config.epochs_between_resets: not implemented in rlchain yet"):
        parse(base_config)
    base_config["params"]["config"].pop("epochs_between_resets")
    base_config["params"]["config"]["freeze_critic"] = True
    with pytest.raises(ConfigError, match=r"params.config.freeze_critic: not implemented"):
        parse(base_config)
    base_config["params"]["config"]["freeze_critic"] = False
    base_config["params"]["config"]["phasic_policy_gradients"] = {"a": 1}
    with pytest.raises(ConfigError, match=r"phasic policy gradients"):
        parse(base_config)


def test_two_action_heads_rejected(base_config):
    base_config["params"]["network"]["space"]["continuous"] = {}
    with pytest.raises(ConfigError, match="choose one action head"):
        parse(base_config)


def test_missing_blocks(base_config):
    del base_config["params"]["algo"]
    with pytest.raises(ConfigError, match="params.algo: required key is missing"):
        parse(base_config)
    with pytest.raises(ConfigError, match="params: required top-level key"):
        parse({"config": {}})


def test_overrides_and_json(tmp_path, base_config):
    path = tmp_path / "cfg.json"
    path.write_text(json.dumps(base_config))
    params = load_config(str(path), ["params.config.learning_rate=1e-3", "config.gamma=0.9"])
    assert params.config.learning_rate == pytest.approx(1e-3)
    assert params.config.gamma == pytest.approx(0.9)
    with pytest.raises(ConfigError, match="key.path=value"):
        apply_overrides(base_config, ["nonsense"], "x")


def test_file_errors(tmp_path):
    with pytest.raises(ConfigError, match="config file not found"):
        load_config(str(tmp_path / "missing.yaml"))
    bad = tmp_path / "bad.yaml"
    bad.write_text("params: [unclosed\n")
    with pytest.raises(ConfigError, match=r"bad.yaml: cannot parse file"):
        load_config(str(bad))


def test_shipped_configs_parse():
    import glob
    import os

    from tests.conftest import CONFIGS
    paths = glob.glob(os.path.join(CONFIGS, "*.yaml"))
    assert len(paths) >= 3
    for path in paths:
        load_config(path)


def test_central_value_network_block_typed_or_a_registered_networks_own(base_config):
    from rlchain.config.network import NetworkConfig

    base_config["params"]["config"]["central_value_config"] = {"network": {"mlp": {"units": [8]}}}
    assert isinstance(parse(base_config).config.central_value_config.network, NetworkConfig)
    block = {"name": "testnet", "central_value": True, "mlp": {"units": [64, 32]}}  # rl_games' mhv_mops
    base_config["params"]["config"]["central_value_config"] = {"network": dict(block)}
    assert parse(base_config).config.central_value_config.network == block  # handed to the builder as is


def test_docs_config_md_in_sync():
    # in a fresh process, as the regenerate command runs: a test before this one may have registered an
    # algorithm or a network of its own, which the page must not list
    import os
    import subprocess
    import sys

    from tests.conftest import ROOT
    out = subprocess.run([sys.executable, "-m", "rlchain.config.docs"], cwd=ROOT, capture_output=True, text=True,
                         env=dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")))
    assert out.returncode == 0, out.stderr[-2000:]
    with open(os.path.join(ROOT, "docs", "config.md"), encoding="utf-8") as fh:
        assert fh.read() == out.stdout, "regenerate: python -m rlchain.config.docs > docs/config.md"


@pytest.mark.parametrize("key,value,expect", [
    ("evaluation", {"select_best": "eval"}, "params.config.evaluation.select_best: 'eval' is not one of"),
    ("evaluation", {"interval": -1}, "params.config.evaluation.interval: must be >= 0"),
    ("divergence", {"action": "rolback"}, "did you mean 'rollback'"),
    ("divergence", {"lr_factor": 0}, "params.config.divergence.lr_factor: must be in (0, 1]"),
    ("torch_compile", "fast", "params.config.torch_compile: mode 'fast' is not one of: default, reduce-overhead"),
    ("torch_compile", {"mode": "default", "modee": 1}, "params.config.torch_compile: unknown key 'modee'"),
    ("torch_compile", 3, "params.config.torch_compile: expected false, true, a mode"),
    ("bptt_length", 0, "params.config.bptt_length: must be > 0"),
    ("reward_shaper", {"log_val": "maybe"}, "params.config.reward_shaper.log_val: expected true or false"),
    ("central_value_config", {"network": {}, "mini_epochs": 0},
     "params.config.central_value_config.mini_epochs: must be > 0"),
    ("central_value_config", {"network": {"name": "testnett"}},
     "params.config.central_value_config.network.name: unknown network 'testnett'; did you mean 'testnet'"),
    ("central_value_config", {"network": {"mlp": {"unitss": [8]}}},
     "params.config.central_value_config.network.mlp.unitss: unknown key; did you mean 'units'?"),
])
def test_rlchain_blocks_bad_values(base_config, key, value, expect):
    base_config["params"]["config"][key] = value
    with pytest.raises(ConfigError) as err:
        parse(base_config)
    assert expect in str(err.value)


@pytest.mark.parametrize("where,key", [("network", "joint_obs_actions")])
def test_unimplemented_rl_games_network_features_are_named(base_config, where, key):
    base_config["params"][where][key] = True
    with pytest.raises(ConfigError, match=rf"params.network.{key}: rl_games feature .* is not implemented"):
        parse(base_config)
    base_config["params"][where][key] = False  # off: accepted
    parse(base_config)


def test_minibatch_checked_with_env_before_a_run_folder(base_config, tmp_path):
    """minibatch_size must divide num_actors*horizon_length*agents: checked once the env is built."""
    import os

    from rlchain import Runner

    base_config["params"]["config"].update(minibatch_size=10, train_dir=str(tmp_path / "runs"))
    parse(base_config)  # accepted at load: a multi-agent env could make it divide
    with pytest.raises(ConfigError, match=r"params.config.minibatch_size: batch num_actors\*horizon_length = \d+ "
                                          r"is not divisible by minibatch_size 10"):
        Runner().load(base_config).train()
    assert not os.path.exists(tmp_path / "runs")


@pytest.mark.parametrize("old,new,space", [
    ("discrete_a2c_lstm", "discrete_a2c", {"discrete": None}),
    ("continuous_a2c_lstm", "continuous_a2c", {"continuous": {}}),
    ("continuous_a2c_lstm_logstd", "continuous_a2c_logstd", {"continuous": {}}),
])
def test_old_lstm_model_names_are_presets(base_config, old, new, space, monkeypatch):
    monkeypatch.setattr(compat, "_warned", set())  # compat warns once per process
    base_config["params"]["model"]["name"] = old
    base_config["params"]["network"].update(space=space, rnn={"name": "lstm", "units": 8})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        params = parse(base_config)
    assert params.model.name == new and params.network.rnn.units == 8
    assert any(f"params.model.name: '{old}' is an old rl_games name, read as '{new}'" in str(w.message)
               for w in caught)


def test_old_lstm_model_name_needs_an_rnn(base_config):
    base_config["params"]["model"]["name"] = "discrete_a2c_lstm"
    with pytest.raises(ConfigError) as err:
        parse(base_config)
    msg = str(err.value)
    assert msg.startswith("cfg.yaml: params.model.name: 'discrete_a2c_lstm' is rl_games' old LSTM model, but "
                          "params.network has no rnn block") and "use 'discrete_a2c'" in msg and "\n" not in msg


def test_tf_lstm_block_is_read_as_rnn(base_config, monkeypatch):
    """rl_games' TensorFlow-era network.lstm (smac/v1 configs): one LSTM after the MLP, per trunk."""
    monkeypatch.setattr(compat, "_warned", set())
    base_config["params"]["model"]["name"] = "discrete_a2c_lstm"
    base_config["params"]["network"].update(separate=True, lstm={"units": 32, "concated": False})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        params = parse(base_config)
    rnn = params.network.rnn
    assert (rnn.name, rnn.units, rnn.layers, rnn.before_mlp) == ("lstm", 32, 1, False)
    assert params.network.separate is True
    assert any("params.network.lstm: old rl_games (TensorFlow) spelling, read as rnn: {name: lstm, units: 32}"
               in str(w.message) for w in caught)


@pytest.mark.parametrize("network,expect", [
    ({"separate": True, "lstm": {"units": 32, "concated": True}},
     "params.network.lstm.concated: rl_games feature 'one LSTM over both separate trunks' is not implemented"),
    ({"lstm": {"units": 32}, "rnn": {"units": 8}}, "params.network.lstm: both 'lstm' (old rl_games spelling) and "
                                                   "'rnn' given"),
    ({"lstm": {"units": 32, "layers": 2}}, "params.network.lstm.layers: unknown key"),
    ({"lstm": 64}, "params.network.lstm: expected {units: N, concated: False}"),
])
def test_tf_lstm_block_bad_input(base_config, network, expect):
    base_config["params"]["network"].update(network)
    with pytest.raises(ConfigError) as err:
        parse(base_config)
    assert expect in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("block,key,value,expect", [
    ("config", "checkpoint_names", "rl_games", "params.config.checkpoint_names: 'rl_games' is not one of"),
    ("config", "save_frequency_frames", -1, "params.config.save_frequency_frames"),
    ("network.mlp", "dropout", 1.5, "params.network.mlp.dropout: expected 0 <= dropout < 1"),
    ("network.mlp", "norm_after_activation", "maybe", "params.network.mlp.norm_after_activation"),
])
def test_checkpoint_name_and_mlp_keys_reject_wrong_values_in_one_line(base_config, block, key, value, expect):
    target = base_config["params"]
    for part in block.split("."):
        target = target[part]
    target[key] = value
    with pytest.raises(ConfigError) as err:
        parse_params(base_config, "cfg.yaml")
    assert expect in str(err.value) and "cfg.yaml" in str(err.value) and "\n" not in str(err.value)
