"""RLlib's PPO train batch over rlchain's rollout (rlchain.algos.ppo.rllib_batch): the rows with RLlib's masked
bootstrap rows, their advantages and RLlib's standardization, and RLlib's cyclic minibatch order, with
hand-checkable numbers; then the PPO agent's update in that order (``minibatch_order: rllib``)."""

import math

import numpy as np
import pytest
import torch

from rlchain.algos.ppo.rllib_batch import (
    BOOTSTRAP,
    batch_rows,
    bootstrap_advantages,
    cyclic_minibatches,
    rllib_standardized,
)
from tests.unit.test_ppo_kl import ENVS, HORIZON, _agent, _rollout_one_away


def test_rows_are_each_envs_chunks_with_a_bootstrap_row_after_each():
    dones = np.array([[True, False], [False, False], [False, True]])  # T=3, N=2
    # env 0: step 0 ends an episode, steps 1-2 an unfinished chunk; env 1: one episode ending at its last step
    assert batch_rows(dones).tolist() == [0, -1, 2, 4, -1, 1, 3, 5, -1]


def _reference_advantages(rows, dones, terminated, rewards, values, final_values, last_values, gamma, lam):
    """RLlib's GAE over its concatenated batch, written out from its rules: a chunk's last real step is
    terminated or truncated (an unfinished chunk counts as truncated), its extra row holds V(final obs) with reward
    0 and neither flag; delta_t = r_t + gamma * (1 - term_t) * V_{t+1} - V_t, A_t = delta_t + gamma * lam *
    (1 - term_t) * (1 - trunc_t) * A_{t+1}, over the rows as one sequence (V after the last row: 0)."""
    n_envs = dones.shape[1]
    v, r, term, trunc = [], [], [], []
    for i, row in enumerate(rows):
        if row == BOOTSTRAP:
            t, n = divmod(int(rows[i - 1]), n_envs)
            v.append(final_values[t, n] if dones[t, n] else last_values[n])
            r.append(0.0), term.append(False), trunc.append(False)
        else:
            t, n = divmod(int(row), n_envs)
            last = i + 1 < len(rows) and rows[i + 1] == BOOTSTRAP
            v.append(values[t, n]), r.append(rewards[t, n])
            term.append(bool(last and terminated[t, n])), trunc.append(bool(last and not terminated[t, n]))
    v, adv, running = np.array(v + [0.0]), np.zeros(len(rows)), 0.0
    for i in reversed(range(len(rows))):
        delta = r[i] + gamma * (not term[i]) * v[i + 1] - v[i]
        running = delta + gamma * lam * (not term[i]) * (not trunc[i]) * running
        adv[i] = running
    return adv


def _face_advantages(dones, terminated, rewards, values, final_values, last_values, gamma, lam):
    """rlchain's GAE on the rollout (time-outs and chunk ends bootstrapped, terminations not)."""
    from rlchain.algos.core.returns import gae, next_values_from_rollout

    as_t = lambda x: torch.as_tensor(np.asarray(x, np.float32)).unsqueeze(-1)
    nxt = next_values_from_rollout(as_t(values), as_t(last_values), as_t(final_values), torch.as_tensor(dones))
    adv, _ = gae(as_t(rewards), as_t(values), nxt, torch.as_tensor(terminated), torch.as_tensor(dones), gamma, lam)
    return adv.squeeze(-1).numpy()


def test_bootstrap_rows_advantage_by_hand():
    # one env, T=3: an episode ends (terminated) at t=1, an unfinished chunk at t=2
    dones = np.array([[False], [True], [False]])
    values, final_values = np.array([[1.0], [2.0], [3.0]]), np.array([[0.0], [5.0], [0.0]])
    advantages, last_values = np.array([[0.5], [-1.0], [0.25]]), np.array([7.0])
    rows = batch_rows(dones)
    assert rows.tolist() == [0, 1, -1, 2, -1]
    got = bootstrap_advantages(rows, dones, values, final_values, last_values, advantages, gamma=0.5, lam=1.0)
    # after the episode: 0.5 * (V(s_2) 3 + 1.0 * A_2 0.25) - V(final obs) 5; after the batch's last row: -V 7
    assert got.tolist() == pytest.approx([0.5 * (3.0 + 0.25) - 5.0, -7.0])


@pytest.mark.parametrize("lam", [1.0, 0.9])
def test_face_gae_and_bootstrap_rows_equal_rllibs_gae_over_its_batch(lam):
    rng = np.random.default_rng(3)
    horizon, envs, gamma = 12, 3, 0.9
    dones = rng.random((horizon, envs)) < 0.25
    terminated = dones & (rng.random((horizon, envs)) < 0.5)
    rewards, values = rng.normal(size=(horizon, envs)), rng.normal(size=(horizon, envs))
    final_values = np.where(dones, rng.normal(size=(horizon, envs)), 0.0)
    last_values = rng.normal(size=envs)
    rows = batch_rows(dones)
    expected = _reference_advantages(rows, dones, terminated, rewards, values, final_values, last_values, gamma, lam)
    face = _face_advantages(dones, terminated, rewards, values, final_values, last_values, gamma, lam)
    real = rows != BOOTSTRAP
    assert face.reshape(-1)[rows[real]] == pytest.approx(expected[real], abs=1e-5)
    extra = bootstrap_advantages(rows, dones, values, final_values, last_values, face, gamma, lam)
    assert extra == pytest.approx(expected[~real], abs=1e-5)


def test_standardized_over_the_bootstrap_rows_too_with_numpys_std():
    out = rllib_standardized(torch.tensor([[1.0], [2.0], [3.0]]), np.array([6.0]))
    # mean over 1, 2, 3, 6 = 3; population std sqrt((4 + 1 + 0 + 9) / 4)
    assert out.flatten().tolist() == pytest.approx([(x - 3.0) / math.sqrt(3.5) for x in (1.0, 2.0, 3.0)])
    assert out.shape == (3, 1) and out.dtype == torch.float32


def test_standardized_std_is_floored_at_1e_4():
    out = rllib_standardized(torch.tensor([2.0, 2.0]), np.array([2.0 + 1e-6]))
    assert out.abs().max().item() < 1e-2  # divided by 1e-4, not by the tiny std


def _fixed_permutations():
    """Reversal at every wrap (deterministic; calls are counted)."""
    calls = []

    def permutation(size):
        calls.append(size)
        return np.arange(size)[::-1]

    return permutation, calls


def test_cyclic_first_pass_in_order_then_wraps_with_a_shuffle():
    permutation, calls = _fixed_permutations()
    groups = cyclic_minibatches(10, 4, 2, permutation)
    flat = [mb.tolist() for group in groups for mb in group]
    # ceil(2 * 10 / 4) = 5 minibatches; the third takes rows 8-9, wraps (reversed order), then rows 9, 8
    assert flat == [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 9, 8], [7, 6, 5, 4], [3, 2, 1, 0]]
    assert [len(g) for g in groups] == [3, 2]  # grouped by the pass each minibatch starts in
    assert calls == [10, 10]  # a shuffle at each wrap, the last one included


def test_cyclic_wrap_at_an_exact_end_counts_the_pass():
    permutation, calls = _fixed_permutations()
    flat = [mb.tolist() for g in cyclic_minibatches(8, 4, 2, permutation) for mb in g]
    assert flat == [[0, 1, 2, 3], [4, 5, 6, 7], [7, 6, 5, 4], [3, 2, 1, 0]]
    assert len(calls) == 2


@pytest.mark.parametrize("size, minibatch, epochs", [(4240, 128, 6), (4011, 128, 6), (1040, 128, 30), (5, 8, 3)])
def test_cyclic_covers_every_row_epochs_times_in_rllibs_count_of_minibatches(size, minibatch, epochs):
    torch.manual_seed(0)
    groups = cyclic_minibatches(size, minibatch, epochs)
    batches = [mb for g in groups for mb in g]
    assert len(batches) == math.ceil(epochs * size / minibatch)  # 4240 rows: 199 (RLlib's count at the start)
    assert all(len(mb) == minibatch for mb in batches)
    counts = np.bincount(np.concatenate(batches), minlength=size)
    assert counts.min() >= epochs and counts.sum() == len(batches) * minibatch


def test_cyclic_order_is_deterministic_for_a_seed():
    torch.manual_seed(5)
    a = [mb.tolist() for g in cyclic_minibatches(300, 128, 3) for mb in g]
    torch.manual_seed(5)
    b = [mb.tolist() for g in cyclic_minibatches(300, 128, 3) for mb in g]
    torch.manual_seed(6)
    c = [mb.tolist() for g in cyclic_minibatches(300, 128, 3) for mb in g]
    assert a == b and a != c


def test_agent_update_takes_rllibs_minibatches_without_the_bootstrap_rows():
    # T=4, N=2, minibatch 3, 2 epochs; env 0 ends an episode at t=1: rows 0 2 -1 4 6 -1 1 3 5 7 -1 (11)
    agent = _agent(kl_reference="rollout", minibatch_order="rllib", minibatch_size=3, lr_schedule=None)
    storage = _rollout_one_away(agent)
    storage.dones[1, 0] = True
    seen = []
    original = storage.rows_batch
    storage.rows_batch = lambda index, adv: seen.append(index.tolist()) or original(index, adv)
    torch.manual_seed(0)
    agent.update(storage, progress=0.0)
    assert HORIZON * ENVS == 8
    # ceil(2 * 11 / 3) = 8 minibatches of RLlib's, none of them all bootstrap rows; the first pass in order
    assert len(seen) == 8
    assert seen[:3] == [[0, 2], [4, 6], [1, 3, 5]]
    assert all(i in range(8) for batch in seen for i in batch)
