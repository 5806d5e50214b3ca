"""appo / impala config: the appo block, keys that make no sense for the algo, cross-key checks."""

import copy

import pytest

from rlchain.config.appo import APPOConfig, ImpalaConfig
from rlchain.config.errors import ConfigError
from rlchain.config.load import parse_params

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


@pytest.mark.parametrize("algo,key,value,words", [
    ("appo", "tau", 0.95, "GAE's lambda"),
    ("appo", "env_groups", 2, "runners step their envs"),
    ("appo", "seq_length", 4, "RNN"),
    ("impala", "e_clip", 0.2, "no clipped surrogate"),
    ("impala", "mini_epochs", 4, "one pass"),
    ("a2c_discrete", "appo", {"max_policy_lag": 2}, "algos appo and impala"),
])
def test_keys_that_make_no_sense_for_the_algo_are_one_line_errors(algo, key, value, words):
    with pytest.raises(ConfigError) as err:
        parse(algo, **{key: value})
    text = str(err.value)
    assert text.startswith(f"cfg.yaml: params.config.{key}: not used by algo {algo}") and words in text
    assert "\n" not in text


@pytest.mark.parametrize("config,key,words", [
    ({"appo": {"max_policy_lag": 0, "broadcast_interval": 3}}, "appo.max_policy_lag", "every fragment"),
    ({"num_actors": 9}, "env_runners.num_workers", "equal env slices"),
    ({"appo": {"learner_queue_size": 0}}, "appo.learner_queue_size", "must be > 0"),
    ({"appo": {"runners": "threads"}}, "appo.runners", "local"),
    ({"appo": {"max_lag": 2}}, "appo.max_lag", "did you mean 'max_policy_lag'"),
])
def test_bad_appo_values(config, key, words):
    with pytest.raises(ConfigError) as err:
        parse(**config)
    assert f"params.config.{key}" in str(err.value) and words in str(err.value)
