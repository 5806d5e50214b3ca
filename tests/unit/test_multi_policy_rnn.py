"""Recurrent policies in multi-policy PPO (rlchain/algos/multi_policy): each policy's LSTM states through the
rollout, whole sequences in the update with the inactive steps weighing 0 in the loss, play and the RLlib face.

The env is rlchain/envs/examples/pz_dying.py: agents that end early and one that appears at step 2 (5-step
episodes), so every policy's rows have inactive steps inside its sequences.
"""

import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.algos.core.losses import policy_loss
from rlchain.algos.core.storage import Batch
from rlchain.algos.multi_policy.masked import active_sequences
from rlchain.algos.ppo.loss import ppo_loss
from tests.unit.test_pettingzoo import dying


def recurrent(tmp_path=None, **config):
    raw = dying(tmp_path, seq_length=4, minibatch_size=16, **config)
    raw["params"]["network"]["rnn"] = {"name": "lstm", "units": 8, "layers": 1}
    return raw


def test_the_update_sequences_replay_the_rollouts_states(tmp_path):
    """Before any gradient step, the update's forward pass over whole sequences gives every active step the
    log-prob the rollout recorded for it: the states entering each sequence are the rollout's, and the RNN ran
    through the inactive steps in both."""
    from rlchain.algos.multi_policy.multi_policy import MultiPolicyPPO
    from rlchain.models.build import build_env, build_model
    from rlchain.runs.logging import TrainLogger
    from rlchain.training.loop import Loop

    runner = Runner().load(recurrent(tmp_path))
    env = build_env(runner.params, 4, 3)
    model = build_model(runner.params, env, torch.device("cpu"))
    trainer = Loop(runner.params, MultiPolicyPPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 3,
                   runner.raw).algorithm
    trainer.start()
    assert trainer.collect() and trainer.collect()  # the second rollout starts from carried states
    for name in ("runners", "late"):
        lr = trainer.learner(name)
        assert lr.model.is_rnn and lr.storage.resets.any()
        checked = 0
        for batch in active_sequences(lr.storage, lr.active, lr.cfg, torch.zeros(12, lr.rows)):
            with torch.no_grad():
                params, _, _ = lr.model.evaluate(batch.obs, batch.states, batch.resets, batch.seq_length)
            log_probs = lr.model.dist.log_prob(params, batch.actions)
            on = batch.weights > 0
            assert torch.allclose(log_probs[on], batch.log_probs[on], atol=1e-5), name
            checked += int(on.sum())
        assert checked == int(lr.active[-12:].sum())  # every active step, each once
    env.close()


def test_weighted_rows_give_the_loss_of_the_weighted_subset():
    torch.manual_seed(0)
    runner = Runner().load(dying())
    from rlchain.models.build import build_env, build_model

    env = build_env(runner.params, 2, 0)
    model = build_model(runner.params, env, torch.device("cpu"))["runners"]
    cfg = runner.params.policies["runners"].config
    n = 6
    batch = Batch(obs=torch.randn(n, 3), actions=torch.randint(0, 3, (n,)), log_probs=torch.randn(n) - 1.0,
                  values=torch.randn(n, 1), returns=torch.randn(n, 1), advantages=torch.randn(n),
                  params=torch.randn(n, 3))
    keep = torch.tensor([1, 0, 1, 1, 0, 1], dtype=torch.bool)
    weighted = Batch(**{**batch.__dict__, "weights": keep.float()})
    subset = Batch(**{k: (v[keep] if isinstance(v, torch.Tensor) else v) for k, v in batch.__dict__.items()})
    coef = torch.tensor(0.01)
    full = ppo_loss(model, cfg, weighted, coef, weighted.params, policy_loss)
    part = ppo_loss(model, cfg, subset, coef, subset.params, policy_loss)
    assert torch.allclose(full[0], part[0], atol=1e-6) and torch.allclose(full[1], part[1], atol=1e-6)
    env.close()


def test_recurrent_policies_train_resume_and_play(tmp_path):
    runner = Runner().load(recurrent(tmp_path))
    result = runner.train()
    assert result.epoch == 3
    path = f"{result.run_dir}/nn/last_dying.pth"
    assert Runner().load(recurrent(tmp_path, max_epochs=4)).train(checkpoint=path).epoch == 4
    played = Runner().load(recurrent()).play(path, quiet=True)
    assert played.games >= 4 and set(played.mean_rewards) == {"runners", "late"}


def test_a_recurrent_self_play_snapshot_is_one_line(tmp_path):
    from rlchain.config.errors import ConfigError

    raw = recurrent(tmp_path, self_play_config={"update_score": 1.0, "games_to_check": 10})
    raw["params"]["config"]["multi_agent"].update(policies_to_train=["runners"], snapshots={"late": "runners"})
    with pytest.raises(ConfigError, match=r"multi_agent.snapshots.late: a self-play snapshot plays without RNN "
                                          r"states") as info:
        Runner().load(raw).train()
    assert "\n" not in str(info.value)


def test_rllib_use_lstm_trains_each_multi_agent_policy(tmp_path, monkeypatch):
    from rlchain.rllib.algorithms.ppo import PPOConfig
    from rlchain.rllib.env.multi_agent_env import make_multi_agent

    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment(make_multi_agent("CartPole-v1"), env_config={"num_agents": 2})
              .training(train_batch_size=64, minibatch_size=32, num_epochs=1)
              .rl_module(model_config={"use_lstm": True, "lstm_cell_size": 8, "max_seq_len": 8,
                                       "fcnet_hiddens": [8]})
              .multi_agent(policies={"p0", "p1"}, policy_mapping_fn=lambda aid, *a, **kw: f"p{aid}"))
    algo = config.build_algo()
    try:
        result = algo.train()
        assert set(result["learners"]) >= {"p0", "p1"}
        assert np.isfinite(result["learners"]["p0"]["policy_loss"])
        assert algo._stepper.context.model["p0"].is_rnn
    finally:
        algo.stop()


@pytest.fixture(autouse=True)
def _one_thread():
    torch.set_num_threads(1)
