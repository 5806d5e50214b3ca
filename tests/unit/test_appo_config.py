"""appo / impala config: the appo block, keys of another algo (a warning), unknown keys (an error), cross-key
checks."""

import copy
import dataclasses
import os

import pytest

from rlchain.config import compat
from rlchain.config.actor_critic import ActorCriticConfig, check_batch
from rlchain.config.appo import APPOConfig, ImpalaConfig
from rlchain.config.errors import ConfigError
from rlchain.config.load import load_config, parse_params
from rlchain.config.ppo import PPOConfig
from rlchain.config.resolve import config_state, params_from_state
from rlchain.config.run import RunConfig
from rlchain.registry import ALGOS
from tests.conftest import ROOT

APPO = {
    "params": {
        "algo": {"name": "appo"},
        "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [16]}},
        "config": {"env_name": "CartPole-v1", "device": "cpu", "num_actors": 8, "horizon_length": 8,
                   "minibatch_size": 32, "env_runners": {"num_workers": 2},
                   "appo": {"vtrace_clip_rho": 1.0, "vtrace_clip_c": 1.0, "max_policy_lag": 4,
                            "learner_queue_size": 16, "broadcast_interval": 1}},
    }
}


def parse(algo="appo", **config):
    raw = copy.deepcopy(APPO)
    raw["params"]["algo"]["name"] = algo
    raw["params"]["config"].update(config)
    return parse_params(raw, "cfg.yaml")


def test_the_issue_block_parses_typed():
    params = parse()
    assert isinstance(params.config, APPOConfig)
    assert params.config.appo.max_policy_lag == 4 and params.config.appo.runners == "auto"
    impala = parse("impala")
    assert isinstance(impala.config, ImpalaConfig) and impala.config.mini_epochs == 1


@pytest.mark.parametrize("algo,key,value,owners,words", [
    ("appo", "tau", 0.95, "a2c_continuous, a2c_discrete, grpo", "GAE's lambda"),
    ("appo", "env_groups", 2, "a2c_continuous, a2c_discrete, grpo", "runners step their envs"),
    ("appo", "zero_rnn_on_done", False, "a2c_continuous, a2c_discrete, grpo", "RNN"),
    ("impala", "e_clip", 0.2, "a2c_continuous, a2c_discrete, appo, grpo", "no clipped surrogate"),
    ("impala", "mini_epochs", 4, "a2c_continuous, a2c_discrete, appo, distill, grpo", "one pass"),
    ("a2c_discrete", "appo", {"max_policy_lag": 2}, "appo, impala", ""),
    ("sac", "learning_rate", 1e-3, "a2c_continuous, a2c_discrete, apg, appo, distill, dqn, grpo, impala", ""),
])
def test_a_key_of_another_algo_is_a_one_line_warning(monkeypatch, scoped_registries, algo, key, value, owners,
                                                     words):
    """rl_games' PPO YAML switched to appo keeps loading: PPO's keys are ignored with a warning naming them."""
    monkeypatch.setattr(compat, "_warned", set())  # compat warns once per process
    # the owners listed are every registered algo that has the key: only rlchain's own here, not one a test
    # registered before (the user REINFORCE algo of tests/smoke has PPO's keys too)
    for name in ALGOS.names():
        if not ALGOS.get(name).__module__.startswith("rlchain."):
            ALGOS.unregister(name)
    raw = copy.deepcopy(APPO)
    raw["params"]["algo"]["name"] = algo
    if algo == "sac":
        raw["params"]["model"]["name"] = "soft_actor_critic"
        raw["params"]["network"] = {"name": "soft_actor_critic", "space": {"continuous": None}}
        for other in ("appo", "minibatch_size", "horizon_length"):
            del raw["params"]["config"][other]
    raw["params"]["config"][key] = value
    with pytest.warns(compat.RlchainDeprecationWarning) as record:
        params = parse_params(raw, "cfg.yaml")
    assert len(record) == 1
    text = str(record[0].message)
    assert text.startswith(f"cfg.yaml: params.config.{key}: a key of algo {owners}, ignored by algo {algo}")
    assert words in text and "\n" not in text
    assert key not in {f.name for f in dataclasses.fields(params.config)}


@pytest.mark.parametrize("algo,key,words", [
    ("appo", "taux", "did you mean 'tau"),  # no algo has it: an error
    ("appo", "learning_rat", "did you mean 'learning_rate'"),
    ("a2c_discrete", "vtrace_clip_c", "unknown key"),  # a key of the appo block, not of params.config
])
def test_a_key_no_algo_has_stays_an_error(algo, key, words):
    with pytest.raises(ConfigError) as err:
        parse(algo, **{key: 1})
    text = str(err.value)
    assert text.startswith(f"cfg.yaml: params.config.{key}: unknown key") and "\n" not in text
    if "did you mean" in words:
        assert words.split("'")[0] in text


def test_each_algo_has_its_own_class_and_no_forbidden_keys():
    """appo and impala share the actor-critic keys with PPO, not PPO's own (no key they then forbid)."""
    def keys(cls):
        return {f.name for f in dataclasses.fields(cls)}
    shared = keys(ActorCriticConfig)
    assert issubclass(PPOConfig, ActorCriticConfig) and issubclass(APPOConfig, ActorCriticConfig)
    assert not issubclass(APPOConfig, PPOConfig) and not issubclass(ImpalaConfig, APPOConfig)
    assert {"learning_rate", "minibatch_size", "horizon_length", "critic_coef"} <= shared
    assert {"tau", "env_groups", "seq_length", "torch_compile", "central_value_config"} <= keys(PPOConfig) - shared
    ppo_only = keys(PPOConfig) - keys(APPOConfig)
    for key in ("tau", "env_groups", "central_value_config", "self_play_config", "use_action_masks",
                "bptt_length", "zero_rnn_on_done", "torch_compile"):
        assert key in ppo_only and key not in keys(RunConfig)
    assert "seq_length" in keys(APPOConfig) & keys(ImpalaConfig)  # their recurrent policies train sequences
    assert keys(APPOConfig) - keys(ImpalaConfig) == {"mini_epochs", "e_clip", "clip_value", "use_smooth_clamp",
                                                     "kl_loss_coef", "kl_loss_target", "target_update_interval"}
    impala = parse("impala").config  # its fixed values are class attributes, not keys: nothing is written
    assert (impala.mini_epochs, impala.e_clip, impala.clip_value) == (1, 0.2, False)
    assert impala.bptt_length is None and impala.use_action_masks is False  # read by the shared PPO agent


def test_config_as_names_the_algo():
    params = parse()
    assert params.config_as(APPOConfig) is params.config and params.config_as(RunConfig) is params.config
    with pytest.raises(ConfigError) as err:
        params.config_as(PPOConfig)
    assert str(err.value) == ("cfg.yaml: params.algo.name: algo appo configures a APPOConfig; this needs a "
                              "PPOConfig (the params.config of another algorithm)")


def test_rl_games_cartpole_yaml_loads_as_appo_and_impala(monkeypatch):
    """The issue's case: rl_games' own cartpole YAML with algo appo stopped on tau."""
    monkeypatch.setattr(compat, "_warned", set())
    path = os.path.join(ROOT, "benchmarks", "rl_games_configs", "ppo_cartpole.yaml")
    for algo in ("appo", "impala"):
        with pytest.warns(compat.RlchainDeprecationWarning, match="params.config.tau: a key of algo"):
            params = load_config(path, [f"params.algo.name={algo}"])
        assert params.config.horizon_length == 32 and params.config.learning_rate == 2e-4


def test_a_checkpoint_config_with_another_algos_key_is_an_error_naming_it():
    """A checkpoint's config is this rlchain's resolved config: a key of another algorithm is not read back."""
    state = config_state(parse("impala"))["params"]
    state["config"].update(tau=0.95)
    with pytest.raises(ConfigError, match=r"old.pth.*params.config.tau"):
        params_from_state(state, "old.pth")


@pytest.mark.parametrize("config,key,words", [
    ({"appo": {"max_policy_lag": 0, "broadcast_interval": 3}}, "appo.max_policy_lag", "every fragment"),
    ({"num_actors": 9}, "env_runners.num_workers", "equal env slices"),
    ({"appo": {"learner_queue_size": 0}}, "appo.learner_queue_size", "must be > 0"),
    ({"appo": {"runners": "threads"}}, "appo.runners", "local"),
    ({"appo": {"max_lag": 2}}, "appo.max_lag", "did you mean 'max_policy_lag'"),
    ({"kl_loss_coef": -0.5}, "kl_loss_coef", "must be >= 0"),
    ({"kl_loss_target": 0.0}, "kl_loss_target", "must be > 0"),
    ({"target_update_interval": 0}, "target_update_interval", "must be > 0"),
    ({"target_update_intervall": 2}, "target_update_intervall", "did you mean 'target_update_interval'"),
])
def test_bad_appo_values(config, key, words):
    with pytest.raises(ConfigError) as err:
        parse(**config)
    assert f"params.config.{key}" in str(err.value) and words in str(err.value)
    assert str(err.value).startswith("cfg.yaml: ") and "\n" not in str(err.value)


@pytest.mark.parametrize("algo", ["appo", "impala"])
@pytest.mark.parametrize("config,words", [
    ({"seq_length": 3}, "horizon_length 8 is not divisible by seq_length 3"),
    ({"seq_length": 8, "minibatch_size": 4, "num_actors": 8}, "minibatch_size 4 is not divisible by seq_length 8"),
    ({"seq_length": 0}, "must be > 0"),
])
def test_a_recurrent_policys_sequences_must_tile_fragment_and_minibatch(algo, config, words):
    raw = copy.deepcopy(APPO)
    raw["params"]["algo"]["name"] = algo
    raw["params"]["network"]["rnn"] = {"name": "lstm", "units": 8}
    raw["params"]["config"].update(config)
    with pytest.raises(ConfigError) as err:
        parse_params(raw, "cfg.yaml")
    assert str(err.value).startswith("cfg.yaml: params.config.seq_length: ") and words in str(err.value)
    raw["params"]["config"].update(seq_length=4, minibatch_size=32)  # 4 divides both: loads
    assert parse_params(raw, "cfg.yaml").config.seq_length == 4


@pytest.mark.parametrize("minibatch_size,words", [
    (48, "batch num_actors*horizon_length = 64 is not divisible by minibatch_size 48"),
    (128, "minibatch_size 128 is larger than the batch num_actors*horizon_length = 64"),
])
def test_minibatch_against_the_learner_batch_once_the_env_is_known(minibatch_size, words):
    """Accepted at load (a multi-agent env could make it divide), refused by the one batch check."""
    params = parse(minibatch_size=minibatch_size)
    with pytest.raises(ConfigError) as err:
        check_batch(params.config, params.source)
    assert "params.config.minibatch_size" in str(err.value) and words in str(err.value)
