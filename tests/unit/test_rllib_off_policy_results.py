"""What the face's DQN and SAC ``learners/<module>`` results mean, as RLlib 2.60's: each gradient step's losses and
Q statistics averaged over the iteration's gradient steps (RLlib logs each step's with ``window=1``, one value per
``LearnerGroup.update()``, and the Algorithm's logger averages the iteration's), under RLlib's key names, with
RLlib's trained-steps and target-update counters."""

import contextlib
import math
from types import SimpleNamespace

import pytest
import torch
import torch.nn.functional as F

from rlchain.algos.off_policy.dqn import DQN as RlchainDQN
from rlchain.algos.off_policy.dqn_agent import DQNAgent
from rlchain.algos.off_policy.sac_agent import SACAgent, q_values
from rlchain.config.off_policy import DQNConfig
from rlchain.rllib.algorithms.dqn import DQN
from rlchain.rllib.algorithms.sac import SAC
from rlchain.rllib.core import ALL_MODULES
from rlchain.rllib.off_policy_results import (
    FRAMES,
    LR,
    TargetUpdates,
    dqn_results,
    last_target_update_frames,
    live_learning_rates,
    sac_results,
)
from rlchain.rllib.results import train_result
from tests.unit.test_sac_dqn import batch, q_model, sac_model

# RLlib 2.60's learners/default_policy keys after train() (DQN on CartPole, SAC on Pendulum, torch, one local
# learner), less those the face does not report: throughputs, num_trainable_parameters, weights_seq_no and DQN's
# gradients_default_optimizer_global_norm (rlchain's DQN does not read its gradients' norm back from the device)
RLLIB_DQN_KEYS = {"default_optimizer_learning_rate", "last_target_update_ts", "module_train_batch_size_mean",
                  "num_module_steps_trained", "num_module_steps_trained_lifetime", "num_target_updates", "qf_loss",
                  "qf_max", "qf_mean", "qf_min", "td_error_mean", "total_loss"}
RLLIB_SAC_KEYS = {"alpha_learning_rate", "alpha_loss", "alpha_value", "last_target_update_ts", "log_alpha_value",
                  "logps", "module_train_batch_size_mean", "num_module_steps_trained",
                  "num_module_steps_trained_lifetime", "num_target_updates", "policy_learning_rate", "policy_loss",
                  "qf_learning_rate", "qf_loss", "qf_max", "qf_mean", "qf_min", "qf_twin_learning_rate",
                  "qf_twin_loss", "target_entropy", "td_error_mean", "total_loss"}
RLLIB_ALL_MODULES_KEYS = {"num_env_steps_trained", "num_env_steps_trained_lifetime", "num_module_steps_trained",
                          "num_module_steps_trained_lifetime"}

DQN_CFG = {"batch_size": 16, "learning_rate": 1e-3, "target_update_frequency": 50, "num_updates_per_step": 1,
           "num_actors": 1}
SAC_CFG = {"batch_size": 32, "actor_lr": 3e-5, "critic_lr": 3e-4, "alpha_lr": 3e-4, "num_updates_per_step": 1,
           "num_actors": 1}


def test_a_dqn_step_reports_rllibs_q_and_td_statistics():
    model = q_model(dueling=False)
    agent = DQNAgent(model, DQNConfig(env_name="x", batch_size=8, learning_rate=1e-9, loss="mse", grad_norm=None))
    agent.rllib_stats = True  # what the face sets (tests/unit/test_off_policy_rllib_stats.py)
    b = batch(8, discrete=True, act_dim=4)
    q = model.network(b["obs"]).detach()[torch.arange(8), b["actions"]]
    stats, td = agent.update(b)
    assert float(stats["q_max"]) == pytest.approx(float(q.max()), abs=1e-5)
    assert float(stats["q_min"]) == pytest.approx(float(q.min()), abs=1e-5)
    assert float(stats["q"]) == pytest.approx(float(q.mean()), abs=1e-5)
    assert float(stats["td_error"]) == pytest.approx(float(td.mean()), abs=1e-6)


def test_a_sac_step_splits_the_critic_loss_and_reports_the_temperature_it_used():
    model, cfg = sac_model(loss="huber", init_alpha=0.2)
    b = batch()
    torch.manual_seed(5)  # the same policy samples for the target here and in the update
    with torch.no_grad():
        next_actions, next_logp = model.policy(b["next_obs"])
        tq1, tq2 = q_values(model.critic_target, b["next_obs"], next_actions)
        target = b["rewards"] + b["discounts"] * (~b["terminated"]).float() * (torch.min(tq1, tq2) - 0.2 * next_logp)
        q1, q2 = q_values(model.network.critic, b["obs"], b["actions"])
    first, twin = F.huber_loss(q1, target), F.huber_loss(q2, target)
    torch.manual_seed(5)
    agent = SACAgent(model, cfg)
    agent.rllib_stats = True  # what the face sets (tests/unit/test_off_policy_rllib_stats.py)
    stats, _ = agent.update(b)
    assert float(stats["critic1_loss"]) == pytest.approx(float(first), rel=1e-5)
    assert float(stats["critic_loss"]) == pytest.approx(float(first + twin), rel=1e-5)
    assert float(stats["alpha_used"]) == pytest.approx(0.2)
    assert float(stats["log_alpha"]) == pytest.approx(math.log(0.2))
    assert float(model.alpha.detach()) != pytest.approx(0.2, abs=1e-7)  # the temperature moved after the step
    assert float(stats["q_pi_min"]) <= float(stats["q_pi"]) <= float(stats["q_pi_max"])


class _CountingAgent:
    """A fake agent: gradient step k reports k; the target moves every ``every`` steps (recorded with the frames)."""

    def __init__(self, ctx, every):
        self.ctx, self.every, self.updates, self.moves = ctx, every, 0, []

    def update(self, batch):
        self.updates += 1
        if self.updates % self.every == 0:
            self.moves.append(self.ctx.frames)
        return {"td_loss": torch.tensor(float(self.updates))}, None


class _Buffer:
    def __len__(self):
        return 10**6

    def sample(self, n, beta):
        return {"indices": None}

    def update_priorities(self, indices, td):
        pass


def _epoch_runner(num_envs, steps, ups, warmup, every, update_every=1):
    """rlchain's off-policy epoch (``OffPolicyAlgorithm._epoch``) over fakes: an env that only counts frames."""

    class Epoch(RlchainDQN):
        device = "cpu"

        def explore(self, obs):
            return None

    Epoch.num_envs = num_envs
    algo = Epoch.__new__(Epoch)
    ctx = SimpleNamespace(frames=0, update_phase=contextlib.nullcontext)

    def step(obs, actions):
        ctx.frames += num_envs
        return obs

    algo.__dict__.update(
        cfg=SimpleNamespace(num_steps_per_episode=steps, num_warmup_frames=warmup, batch_size=1,
                            num_updates_per_step=ups, update_every=update_every, max_frames=0, max_epochs=0,
                            priority_beta=1.0),
        model=SimpleNamespace(dist=SimpleNamespace(random=lambda n, device: None), eval=lambda: None,
                              train=lambda: None),
        ctx=ctx, stepper=SimpleNamespace(step=step), obs=None, agent=_CountingAgent(ctx, every), buffer=_Buffer())
    return algo, ctx


def test_the_epoch_reports_the_mean_over_its_gradient_steps_and_where_the_target_last_moved():
    algo, ctx = _epoch_runner(num_envs=3, steps=10, ups=2, warmup=12, every=5)
    stats, _, _ = algo._epoch()
    n = algo.agent.updates
    assert stats["updates"] == n == 2 * 7  # learning from the 4th vectorized step (12 frames) on, 2 per step
    assert stats["td_loss"] == pytest.approx(sum(range(1, n + 1)) / n)  # the mean, as RLlib's, not the last (n)
    assert last_target_update_frames(n, n, 5, 2, ctx.frames, 3) == algo.agent.moves[-1]
    first = list(algo.agent.moves)
    stats, _, _ = algo._epoch()  # a second epoch: its own steps only
    total = algo.agent.updates
    assert stats["updates"] == 20 and stats["td_loss"] == pytest.approx(sum(range(n + 1, total + 1)) / 20)
    assert last_target_update_frames(total, 20, 5, 2, ctx.frames, 3) == algo.agent.moves[-1] != first[-1]
    assert last_target_update_frames(total, 20, 50, 2, ctx.frames, 3) is None  # no target update in the epoch


def test_dqn_results_are_rllibs_keys_and_counters():
    stats = {"td_loss": 0.5, "q": 2.0, "q_max": 3.0, "q_min": 1.0, "td_error": 0.7, "epsilon": 0.9,
             "updates": 40, "total_updates": 49, FRAMES: 81, LR + "learning_rate": 5e-4}
    out = dqn_results(stats, DQN_CFG, TargetUpdates())
    every = out.pop(ALL_MODULES)
    assert set(out) - {"curr_lr", "curr_epsilon"} == RLLIB_DQN_KEYS - {"default_optimizer_learning_rate",
                                                                       "num_target_updates", "last_target_update_ts"}
    assert (out["qf_loss"], out["total_loss"], out["qf_mean"], out["qf_max"], out["qf_min"], out["td_error_mean"]) \
        == (0.5, 0.5, 2.0, 3.0, 1.0, 0.7)
    assert out["curr_lr"] == 5e-4  # the optimizer's live rate
    assert every == {"num_env_steps_trained": 640, "num_env_steps_trained_lifetime": 784,
                     "num_module_steps_trained": 640, "num_module_steps_trained_lifetime": 784}
    assert out["num_module_steps_trained"] == 640 and out["module_train_batch_size_mean"] == 16


def test_target_update_counters_appear_with_the_first_update_and_keep_the_last_step():
    targets = TargetUpdates()
    base = {"updates": 40, FRAMES: 80}
    assert "num_target_updates" not in dqn_results({**base, "total_updates": 49}, DQN_CFG, targets)
    out = dqn_results({**base, "total_updates": 89, FRAMES: 120}, DQN_CFG, targets)
    assert (out["num_target_updates"], out["last_target_update_ts"]) == (1.0, 81.0)  # update 50 of 89, at 81
    out = dqn_results({**base, "total_updates": 99, FRAMES: 130}, DQN_CFG, targets)  # updates 90..99: none moved it
    assert (out["num_target_updates"], out["last_target_update_ts"]) == (1.0, 81.0)


def test_sac_results_are_rllibs_keys_and_meanings():
    stats = {"critic_loss": 3.0, "critic1_loss": 1.25, "actor_loss": -2.0, "alpha_loss": 0.1, "alpha_used": 0.5,
             "log_alpha": -0.7, "entropy": 0.6, "q_pi": -1.0, "q_pi_max": 0.0, "q_pi_min": -2.0, "td_error": 0.3,
             "target_entropy": -1.0, "alpha": 0.45, "updates": 10, "total_updates": 30, FRAMES: 60,
             LR + "actor_lr": 1e-4, LR + "critic_lr": 2e-4, LR + "alpha_lr": 3e-4}
    out = sac_results(stats, SAC_CFG, TargetUpdates())
    every = out.pop(ALL_MODULES)
    assert set(out) == RLLIB_SAC_KEYS and set(every) == RLLIB_ALL_MODULES_KEYS
    assert (out["qf_loss"], out["qf_twin_loss"]) == (1.25, 1.75)  # each critic's, not their sum
    assert out["total_loss"] == pytest.approx(-2.0 + 3.0 + 0.1) and out["logps"] == -0.6
    assert (out["alpha_value"], out["log_alpha_value"], out["target_entropy"]) == (0.5, -0.7, -1.0)
    assert (out["qf_mean"], out["qf_max"], out["qf_min"], out["td_error_mean"]) == (-1.0, 0.0, -2.0, 0.3)
    assert (out["policy_learning_rate"], out["qf_learning_rate"], out["qf_twin_learning_rate"],
            out["alpha_learning_rate"]) == (1e-4, 2e-4, 2e-4, 3e-4)
    assert (out["num_target_updates"], out["last_target_update_ts"]) == (30.0, 60.0)  # the target: every step
    assert every["num_env_steps_trained"] == 320 and every["num_env_steps_trained_lifetime"] == 960
    face = SAC.learner_results(SimpleNamespace(), stats, SAC_CFG)  # what the face's SAC reports
    assert (face["qf_loss"], face["qf_twin_loss"]) == (1.25, 1.75) and "entropy" not in face
    face = DQN.learner_results(SimpleNamespace(), {"updates": 40, "total_updates": 40}, DQN_CFG)
    assert face[ALL_MODULES]["num_env_steps_trained"] == 640


def test_the_result_dict_takes_the_learners_own_all_modules_counters():
    report = SimpleNamespace(mean_reward=1.0, mean_length=10.0, frames=80, stats={}, seconds=0.1)
    cfg = {"num_actors": 1, "num_steps_per_episode": 40}
    stats = {"updates": 40, "total_updates": 49, FRAMES: 80}
    result = train_result(report, cfg, iteration=1, time_total=0.1, games=1, episode_custom={},
                          learner=dqn_results(stats, DQN_CFG, TargetUpdates()))
    learners = result["learners"]
    assert learners[ALL_MODULES]["num_env_steps_trained"] == 640  # 40 gradient steps of 16, not 40 env steps
    assert ALL_MODULES not in learners["default_policy"]
    assert train_result(report, cfg, iteration=1, time_total=0.1, games=1, episode_custom={},
                        learner={})["learners"][ALL_MODULES] == {"num_env_steps_trained": 40}  # PPO's: the batch


def test_live_learning_rates_name_each_optimizer():
    model, cfg = sac_model(actor_lr=1e-4)
    rates = live_learning_rates(SACAgent(model, cfg))
    assert rates[LR + "actor_lr"] == 1e-4 and set(rates) == {LR + "actor_lr", LR + "critic_lr", LR + "alpha_lr"}
    assert live_learning_rates(object()) == {}
