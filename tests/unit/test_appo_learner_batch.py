"""The appo / impala learner's batch of a recurrent policy (rlchain.algos.appo.learner_batch): fragments carry the
RNN states entering every step and the episode starts, the learner's pass over whole fragments and the PPO
agent's seq_length sequences from the stored states both give back the runner's own log-probs."""

import copy

import pytest
import torch

from rlchain.algos.appo.fragments import FragmentRunner
from rlchain.algos.appo.learner_batch import FragmentBatch, final_values, policy_pass
from rlchain.algos.core.storage import RolloutStorage
from rlchain.config.load import parse_params
from rlchain.envs.ray.ray_worker import EnvRecipe
from rlchain.models.build import build_model

HORIZON, ENVS, SEQ = 12, 3, 4
RAW = {"params": {
    "algo": {"name": "appo"}, "model": {"name": "discrete_a2c"},
    "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [8]},
                "rnn": {"name": "lstm", "units": 8, "layers": 1}},
    "config": {"env_name": "CartPole-v1", "device": "cpu", "num_actors": ENVS, "horizon_length": HORIZON,
               "minibatch_size": ENVS * HORIZON, "seq_length": SEQ, "env_runners": {"num_workers": 1}}}}


def _runner_and_model(rnn="lstm"):
    torch.manual_seed(0)
    runner = FragmentRunner(EnvRecipe.capture("CartPole-v1", {"max_episode_steps": 7}, "sync"), worker=0, start=0,
                            num_envs=ENVS, horizon=HORIZON)
    runner.build(seed=1)
    raw = copy.deepcopy(RAW)
    raw["params"]["network"]["rnn"]["name"] = rnn
    model = build_model(parse_params(raw, "cfg.yaml"), runner.env, torch.device("cpu"))
    runner.set_policy(copy.deepcopy(model))
    return runner, model.eval()


@pytest.mark.parametrize("rnn,num_states", [("lstm", 2), ("gru", 1)])
def test_fragments_carry_states_and_the_learner_reproduces_the_runners_log_probs(rnn, num_states):
    runner, model = _runner_and_model(rnn)
    first, second = runner.sample(), runner.sample()  # 7-step episodes: several ends inside each fragment
    assert len(first.states) == num_states and first.states[0].shape == (HORIZON + 1, 1, ENVS, 8)
    assert first.resets.shape == (HORIZON + 1, ENVS) and bool(first.resets[0].all())  # fresh envs
    assert bool(first.resets[1:].any()) and first.final_steps.shape[0] > 0
    assert first.final_states[0].shape == (1, first.final_steps.shape[0], 8)
    # the next fragment starts where this one ended: its first row is this one's last
    for a, b in zip(first.states, second.states):
        torch.testing.assert_close(a[-1], b[0])
    torch.testing.assert_close(first.resets[-1], second.resets[0])
    for frag in (first, second):
        batch = FragmentBatch.stack([frag], torch.device("cpu"))
        with torch.no_grad():
            params, values = policy_pass(model, batch)
        log_probs = model.dist.log_prob(params[:HORIZON].reshape(HORIZON * ENVS, -1),
                                        batch.actions.reshape(HORIZON * ENVS))
        torch.testing.assert_close(log_probs.reshape(HORIZON, ENVS), frag.log_probs, atol=1e-5, rtol=1e-5)
        assert values.shape == (HORIZON + 1, ENVS, 1)
        steps, envs, ends = final_values(model, [frag], torch.device("cpu"))
        assert ends.shape == (frag.final_steps.shape[0], 1) and torch.isfinite(ends).all()


def test_training_sequences_start_from_the_stored_states():
    """PPO's sequence minibatches over the learner's storage: seq_length chunks from the runner's stored states
    and the episode starts inside them give every step's log-prob as the runner had it."""
    runner, model = _runner_and_model()
    runner.sample()
    frag = runner.sample()
    batch = FragmentBatch.stack([frag], torch.device("cpu"))
    storage = RolloutStorage(HORIZON, ENVS, (4,), torch.float32, (), torch.long, 2, 1, torch.device("cpu"),
                             state_shapes=tuple(tuple(s.shape) for s in model.initial_state(ENVS)))
    storage.obs.copy_(batch.obs[:HORIZON])
    storage.actions.copy_(batch.actions)
    storage.log_probs.copy_(batch.log_probs)
    for stored, state in zip(storage.states, batch.states):
        stored.copy_(state[:HORIZON])
    storage.resets.copy_(batch.resets[:HORIZON])
    storage.written(HORIZON)
    seen = 0
    for mb in storage.sequence_minibatches(2 * SEQ, SEQ, torch.zeros(HORIZON, ENVS)):
        with torch.no_grad():
            params, _, _ = model.evaluate(mb.obs, mb.states, mb.resets, mb.seq_length)
        torch.testing.assert_close(model.dist.log_prob(params, mb.actions), mb.log_probs, atol=1e-5, rtol=1e-5)
        seen += mb.log_probs.numel()
    assert seen == HORIZON * ENVS
