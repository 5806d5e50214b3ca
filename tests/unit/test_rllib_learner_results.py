"""What the face's ``learners/<module>`` results mean, as RLlib 2.60's: the losses of the update's last minibatch
(RLlib logs them with ``window=1``), a schedule's value after the update (RLlib's Learner steps its schedulers
after each update and logs the new value)."""

import math

import pytest
import torch

from rlchain.algos.ppo import agent as agent_module
from rlchain.rllib.results import LAST, learner_results, scheduled_results, with_last_minibatch
from tests.unit.test_ppo_kl import _agent, _rollout_one_away

MEANS = {"a_loss": 0.5, "c_loss": 2.0, "entropy": 0.7, "kl": 0.01, "grad_norm": 3.0, "lr": 1e-3,
         "entropy_coef": 0.02}


def test_the_agent_keeps_its_last_minibatchs_statistics(monkeypatch):
    agent = _agent(kl_reference="rollout", minibatch_size=2, mini_epochs=2, lr_schedule=None, learning_rate=1e-2)
    storage = _rollout_one_away(agent)
    steps = []
    real = agent_module.optimizer_step
    monkeypatch.setattr(agent_module, "optimizer_step", lambda *a, **kw: steps.append(real(*a, **kw)) or steps[-1])
    torch.manual_seed(0)
    means = agent.update(storage, progress=0.0)
    assert len(steps) == 8  # 2 passes x 4 minibatches of 2 over the 8 steps
    assert agent.last_minibatch_stats is steps[-1] and set(steps[-1]) >= {"a_loss", "c_loss", "entropy", "kl", "loss"}
    assert "loss" not in means  # the total loss is reported for the last minibatch only (RLlib's total_loss)
    assert means["a_loss"] == pytest.approx(sum(s["a_loss"] for s in steps) / len(steps))
    assert means["a_loss"] != steps[-1]["a_loss"]  # the mean is not what RLlib reports


def test_learner_results_report_the_last_minibatch():
    class Agent:
        last_minibatch_stats = {"a_loss": -0.1, "c_loss": 9.0, "entropy": 0.6, "kl": 0.03, "grad_norm": 1.5,
                                "loss": 4.4}

    out = learner_results(with_last_minibatch(MEANS, Agent()))
    assert out["policy_loss"] == -0.1 and out["vf_loss"] == 9.0 and out["entropy"] == 0.6
    assert out["mean_kl_loss"] == 0.03 and out["gradients_default_optimizer_global_norm"] == 1.5
    assert out["curr_lr"] == 1e-3 and out["curr_entropy_coeff"] == 0.02 and out["total_loss"] == 4.4
    assert math.isnan(learner_results(MEANS)["total_loss"])  # no last minibatch: no total loss
    assert with_last_minibatch(MEANS, None) == MEANS  # no agent (or none with the statistics): the means
    assert learner_results(MEANS)["policy_loss"] == 0.5
    assert math.isnan(learner_results({})["policy_loss"])
    assert LAST + "a_loss" in with_last_minibatch(MEANS, Agent())


def test_ppo_reports_the_rows_of_a_minibatch_update():
    # debugging/deterministic_sampling_and_training.py compares module_train_batch_size_mean and total_loss
    from rlchain.rllib.algorithms.ppo import PPO
    out = PPO.learner_results(MEANS, {"minibatch_size": 128})
    assert out["module_train_batch_size_mean"] == 128.0 and out["policy_loss"] == 0.5


def test_scheduled_values_are_reported_under_rllibs_names():
    assert scheduled_results({"learning_rate": 5e-4, "entropy_coef": 0.01}) == \
        {"curr_lr": 5e-4, "curr_entropy_coeff": 0.01}
    assert scheduled_results({"other": 1.0}) == {}


def test_multi_agent_learners_report_each_policys_last_minibatch():
    from types import SimpleNamespace

    from rlchain.rllib.multi_agent import MultiAgentRun
    from rlchain.rllib.results import last_minibatch_by_policy

    run = MultiAgentRun.__new__(MultiAgentRun)  # the parts learners() reads, without an env
    run.names, run.spaces, run.trained = ["p0", "p1"], {"p0": None, "p1": None}, None
    stats = {f"losses/{p}/{k}": 1.0 for p in ("p0", "p1") for k in ("a_loss", "c_loss", "entropy")}
    stats.update({"info/p0/kl": 0.5, "info/p1/kl": 0.5})
    agents = SimpleNamespace(agents={"p0": SimpleNamespace(last_minibatch_stats={"a_loss": -2.0, "c_loss": 3.0,
                                                                                 "entropy": 0.1, "kl": 0.02,
                                                                                 "loss": 1.5}),
                                     "p1": SimpleNamespace(last_minibatch_stats={})})
    out = run.learners(stats, 1e-3, last_minibatch_by_policy(agents))
    assert (out["p0"]["policy_loss"], out["p0"]["vf_loss"], out["p0"]["entropy"], out["p0"]["mean_kl_loss"]) == \
        (-2.0, 3.0, 0.1, 0.02)
    assert (out["p1"]["policy_loss"], out["p1"]["mean_kl_loss"]) == (1.0, 0.5)  # no last minibatch: the means
    assert out["p0"]["total_loss"] == 1.5 and math.isnan(out["p1"]["total_loss"])
    assert run.learners(stats, 1e-3)["p0"]["policy_loss"] == 1.0
