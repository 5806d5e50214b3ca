"""Multi-policy appo / impala (config.multi_agent with algo appo / impala): two policies train on the PettingZoo
env whose agents die and appear (rlchain/envs/examples/pz_dying.py); what is not supported is one line."""

import copy
import os

import pytest

from rlchain import Runner
from rlchain.algos.multi_policy.multi_policy_vtrace import MultiPolicyAPPO, MultiPolicyIMPALA
from rlchain.config.errors import ConfigError
from rlchain.runner import algorithm_class
from rlchain.runs import checkpoint as ckpt

DYING = {
    "params": {
        "seed": 3,
        "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [16]}},
        "config": {"name": "dying", "env_name": "pettingzoo", "device": "cpu", "num_actors": 4,
                   "env_config": {"env": "rlchain.envs.examples.pz_dying", "kwargs": {"runners": 2, "length": 6}},
                   "horizon_length": 12, "minibatch_size": 16, "max_epochs": 2,
                   "print_stats": False, "save_best_after": 0,
                   "multi_agent": {"policies": {"runners": {}, "late": {"config": {"learning_rate": 1e-3}}},
                                   "policy_mapping": {"runner_*": "runners", "late_*": "late"}}},
    }
}


def dying(algo, tmp_path, **config):
    raw = copy.deepcopy(DYING)
    raw["params"]["algo"] = {"name": algo}
    raw["params"]["config"].update(train_dir=str(tmp_path), **config)
    return raw


@pytest.mark.parametrize("algo,extra,rnn", [("appo", {"mini_epochs": 2, "kl_loss_coef": 0.2}, False),
                                            ("impala", {}, False), ("appo", {"seq_length": 4}, True)])
def test_two_policies_train_each_with_its_own_vtrace_learner(tmp_path, algo, extra, rnn):
    raw = dying(algo, tmp_path, **extra)
    if rnn:  # each policy's LSTM keeps its rows' states, as multi-policy PPO's
        raw["params"]["network"]["rnn"] = {"name": "lstm", "units": 8, "layers": 1}
    runner = Runner().load(raw)
    assert algorithm_class(runner.params) is {"appo": MultiPolicyAPPO, "impala": MultiPolicyIMPALA}[algo]
    result = runner.train()
    assert result.epoch == 2
    state = ckpt.load(f"{result.run_dir}/nn/last_dying.pth")
    assert {k.split(".")[0] for k in state["model"]} == {"runners", "late"}
    assert set(state["agent"]) == {"runners", "late"}
    assert state["agent"]["late"]["lr"] == pytest.approx(1e-3)


@pytest.mark.parametrize("change,key", [({"appo": {"runners": "ray"}}, "appo.runners"),
                                        ({"env_runners": {"num_workers": 2}}, "env_runners"),
                                        ({"kl_loss_coef": 0.2, "target_update_interval": 4}, "target_update_interval")])
def test_what_multi_policy_appo_does_not_have_is_one_line(tmp_path, change, key):
    with pytest.raises(ConfigError, match=rf"params.config.{key}: is not supported with multi_agent yet"):
        Runner().load(dying("appo", tmp_path, **change)).train()
    assert not os.listdir(tmp_path)  # refused before a run folder


def test_a_bad_multi_agent_block_under_impala_names_the_key(tmp_path):
    raw = dying("impala", tmp_path)
    raw["params"]["config"]["multi_agent"]["policies"]["late"] = {"config": {"appo": {"vtrace_clip_rho": -1.0}}}
    key = r"multi_agent.policies.late.config.appo.vtrace_clip_rho"
    with pytest.raises(ConfigError, match=rf"{key}: .*must be > 0") as info:
        Runner().load(raw).train()
    assert "\n" not in str(info.value)
