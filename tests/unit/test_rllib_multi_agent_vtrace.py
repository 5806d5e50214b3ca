"""RLlib's MultiAgentEnv under APPOConfig / IMPALAConfig through the face: rlchain's multi-policy appo / impala
(a V-trace learner per policy over the turn-based env's active steps), RLlib's per-policy results, LSTMs."""

import numpy as np
import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.appo import APPOConfig
from rlchain.rllib.algorithms.impala import IMPALAConfig
from rlchain.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
from rlchain.rllib.core.rl_module.rl_module import RLModuleSpec
from tests.unit.test_rllib_multi_agent import TakeTurns


def _config(cls):
    return (cls().environment(TakeTurns).env_runners(num_env_runners=0).debugging(seed=1)
            .training(train_batch_size=64, lr=1e-3)
            .multi_agent(policies={"first", "second"},
                         policy_mapping_fn=lambda aid, *a, **kw: ["first", "second"][aid]))


@pytest.mark.parametrize("cls", [APPOConfig, IMPALAConfig])
def test_two_policies_train_under_vtrace_with_results_per_policy(tmp_path, monkeypatch, cls):
    monkeypatch.chdir(tmp_path)
    algo = _config(cls).build_algo()
    try:
        assert algo.rlchain_config["params"]["algo"]["name"] == cls.__name__[:-6].lower()
        assert "env_runners" not in algo.rlchain_config["params"]["config"]  # stepped in the learner's process
        result = algo.train()
        runners = result["env_runners"]
        assert runners["episode_len_mean"] == 4 and runners["episode_return_mean"] >= 10.0  # player 1's bonus
        assert set(result["learners"]) == {"first", "second", "__all_modules__"}
        for pid in ("first", "second"):
            assert np.isfinite(result["learners"][pid]["policy_loss"])
            assert np.isfinite(result["learners"][pid]["vf_loss"])
    finally:
        algo.stop()


def test_recurrent_policies_train_under_impala(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    algo = _config(IMPALAConfig).rl_module(model_config={"use_lstm": True, "lstm_cell_size": 8,
                                                          "max_seq_len": 4}).build_algo()
    try:
        policies = algo.rlchain_config["params"]["config"]["multi_agent"]["policies"]
        assert all(policies[pid]["network"].get("rnn") for pid in ("first", "second"))
        result = algo.train()
        assert all(np.isfinite(result["learners"][pid]["policy_loss"]) for pid in ("first", "second"))
    finally:
        algo.stop()


def test_each_policy_takes_its_module_spec_and_a_single_agent_spec_is_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    specs = {"first": RLModuleSpec(model_config={"fcnet_hiddens": [8]}),
             "second": RLModuleSpec(model_config={"fcnet_hiddens": [16, 16]})}
    algo = _config(APPOConfig).rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs=specs)).build_algo()
    try:
        shapes = {pid: {tuple(v.shape) for v in algo.get_module(pid).state_dict().values()}
                  for pid in ("first", "second")}
        assert (8, 2) in shapes["first"] and (16, 16) in shapes["second"] and (16, 16) not in shapes["first"]
    finally:
        algo.stop()
    single = APPOConfig().environment("CartPole-v1").rl_module(rl_module_spec=specs["first"])
    with pytest.raises(ConfigError, match="rl_module_spec: an RLModule trains under PPO only, not APPO") as info:
        single.build_algo()
    assert "\n" not in str(info.value)
