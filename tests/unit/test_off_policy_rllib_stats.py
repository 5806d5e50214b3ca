"""rlchain's SAC and DQN agents compute the statistics only RLlib's results report (``rllib_stats``) when the RLlib
face asks for them, and only then: rlchain's own runs and the SB3 face return what they did before the face
reported them (tests/unit/test_rllib_off_policy_results.py checks what the flagged values mean)."""

import math
import os
from types import SimpleNamespace

import pytest
import torch

from rlchain.algos.off_policy.dqn_agent import DQNAgent
from rlchain.algos.off_policy.sac import SAC as RlchainSAC
from rlchain.algos.off_policy.sac_agent import SACAgent
from rlchain.config.off_policy import DQNConfig
from rlchain.runner import Runner
from rlchain.tuning.epochs import EpochStepper
from tests.conftest import CONFIGS
from tests.unit.test_sac_dqn import batch, q_model, sac_model

SAC_KEYS = {"critic_loss", "q", "actor_loss", "alpha_loss", "entropy"}
SAC_RLLIB_ONLY = {"critic1_loss", "alpha_used", "log_alpha", "td_error", "q_pi", "q_pi_max", "q_pi_min"}
DQN_KEYS = {"td_loss", "q"}
DQN_RLLIB_ONLY = {"q_max", "q_min", "td_error"}


def _sac_step(rllib_stats):
    model, cfg = sac_model(policy_frequency=1)
    agent = SACAgent(model, cfg)
    if rllib_stats is not None:
        agent.rllib_stats = rllib_stats
    torch.manual_seed(3)
    stats, td = agent.update(batch())
    return model, agent, stats, td


def _dqn_step(rllib_stats):
    model = q_model(dueling=False)
    agent = DQNAgent(model, DQNConfig(env_name="x", batch_size=8, loss="mse"))
    if rllib_stats is not None:
        agent.rllib_stats = rllib_stats
    stats, td = agent.update(batch(8, discrete=True, act_dim=4))
    return model, agent, stats, td


@pytest.mark.parametrize("step, keys, extra", [(_sac_step, SAC_KEYS, SAC_RLLIB_ONLY),
                                               (_dqn_step, DQN_KEYS, DQN_RLLIB_ONLY)], ids=["sac", "dqn"])
def test_an_agent_returns_rllibs_statistics_only_with_the_flag(step, keys, extra):
    _, _, plain, plain_td = step(None)  # rlchain's own runs and the SB3 face: the class default
    assert set(plain) == keys
    _, _, flagged, flagged_td = step(True)
    assert set(flagged) == keys | extra
    # the flag adds statistics; the step itself (its losses, its TD errors for the priorities) is the same
    for key in keys:
        assert float(flagged[key]) == pytest.approx(float(plain[key]), rel=1e-6, abs=1e-7)
    assert torch.allclose(flagged_td, plain_td)
    assert set(step(False)[2]) == keys


def test_the_flagged_steps_params_are_the_plain_steps():
    plain_model, *_ = _sac_step(False)
    flagged_model, *_ = _sac_step(True)
    for a, b in zip(plain_model.parameters(), flagged_model.parameters()):
        assert torch.equal(a, b)


def test_rlchains_sac_epoch_reports_the_target_entropy_only_for_the_face():
    model, agent, *_ = _sac_step(None)
    algo = SimpleNamespace(model=model, agent=agent)
    assert set(RlchainSAC.extra_stats(algo)) == {"alpha"}
    agent.rllib_stats = True
    assert RlchainSAC.extra_stats(algo)["target_entropy"] == -2.0  # -action dims


@pytest.mark.parametrize("algo, env", [("dqn", "CartPole-v1"), ("sac", "Pendulum-v1")])
def test_the_rllib_face_asks_its_agent_for_rllibs_statistics(algo, env, tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.dqn import DQNConfig as FaceDQNConfig
    from rlchain.rllib.algorithms.sac import SACConfig as FaceSACConfig

    monkeypatch.chdir(tmp_path)
    config = ((FaceDQNConfig if algo == "dqn" else FaceSACConfig)().environment(env)
              .training(train_batch_size_per_learner=8, num_steps_sampled_before_learning_starts=8)
              .rl_module(model_config={"fcnet_hiddens": [8]})
              .reporting(min_sample_timesteps_per_iteration=16).debugging(seed=1))
    built = config.build_algo()
    try:
        agent = built._stepper.context.agent
        assert isinstance(agent, DQNAgent if algo == "dqn" else SACAgent) and agent.rllib_stats is True
        assert type(agent).rllib_stats is False  # the instance's, not every agent's
        learner = built.train()["learners"]["default_policy"]
        assert all(math.isfinite(learner[k]) for k in ("qf_max", "qf_min", "td_error_mean"))
    finally:
        built.stop()


@pytest.mark.parametrize("config, plain, rllib_only", [
    ("sac_pendulum.yaml", SAC_KEYS | {"alpha"}, SAC_RLLIB_ONLY | {"target_entropy"}),
    ("dqn_cartpole.yaml", DQN_KEYS | {"epsilon"}, DQN_RLLIB_ONLY),
])
def test_rlchains_own_runs_report_none_of_rllibs_statistics(config, plain, rllib_only, tmp_path):
    runner = Runner().load(os.path.join(CONFIGS, config), [
        "params.config.num_warmup_frames=40", "params.config.batch_size=16", "params.config.num_steps_per_episode=10",
        "params.config.print_stats=false", f"params.config.train_dir={tmp_path}", "params.config.max_epochs=5"])
    stepper = EpochStepper(runner, seed=1)
    try:
        stats = stepper.next_epoch().stats
        assert plain <= set(stats) and stats["updates"] > 0 and not rllib_only & set(stats)
    finally:
        stepper.shutdown()
