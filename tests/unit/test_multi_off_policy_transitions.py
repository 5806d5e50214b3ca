"""Multi-policy DQN / SAC's replay transitions: from an agent's step to its NEXT active step, rewards summed."""

import torch

from rlchain.algos.multi_off_policy.transitions import NStepRows, OpenTransitions


def _obs(*values):
    return torch.tensor([[float(v)] for v in values])


def test_an_agent_that_waits_a_step_gets_one_transition_with_the_rewards_summed():
    # two rows: row 0 acts every step, row 1 waits at step 1 (turn-based) and acts at steps 0 and 2
    open_ = OpenTransitions(2, (1,), (), torch.long, torch.device("cpu"))
    no = torch.zeros(2, dtype=torch.bool)
    first = open_.act(_obs(0, 10), torch.tensor([1, 2]), torch.tensor([True, True]))
    assert len(first) == 0  # nothing open yet
    assert len(open_.observe(torch.tensor([1.0, 0.5]), no, no, _obs(0, 0))) == 0
    second = open_.act(_obs(1, 11), torch.tensor([3, 4]), torch.tensor([True, False]))
    assert len(second) == 1 and second.obs.tolist() == [[0.0]] and second.next_obs.tolist() == [[1.0]]
    assert second.actions.tolist() == [1] and second.rewards.tolist() == [1.0]
    open_.observe(torch.tensor([2.0, 0.25]), no, no, _obs(0, 0))  # row 1 waits and still collects its reward
    third = open_.act(_obs(2, 12), torch.tensor([5, 6]), torch.tensor([True, True]))
    assert third.obs.tolist() == [[1.0], [10.0]] and third.next_obs.tolist() == [[2.0], [12.0]]
    assert third.actions.tolist() == [3, 2] and third.rewards.tolist() == [2.0, 0.75]
    assert not third.terminated.any() and not third.truncated.any()


def test_an_agents_end_closes_its_transition_at_its_final_observation_and_rows_without_one_add_nothing():
    open_ = OpenTransitions(3, (1,), (), torch.long, torch.device("cpu"))
    open_.act(_obs(0, 10, 20), torch.tensor([1, 2, 0]), torch.tensor([True, True, False]))  # row 2 absent
    ended = open_.observe(torch.tensor([1.0, 2.0, 9.0]), torch.tensor([True, False, True]),
                          torch.tensor([False, True, False]), _obs(7, 17, 27))
    assert ended.obs.tolist() == [[0.0], [10.0]] and ended.next_obs.tolist() == [[7.0], [17.0]]
    assert ended.rewards.tolist() == [1.0, 2.0]  # the absent row's reward goes nowhere
    assert ended.terminated.tolist() == [True, False] and ended.truncated.tolist() == [False, True]
    # the next episode's first step opens new transitions, closing none
    assert len(open_.act(_obs(1, 11, 21), torch.tensor([0, 0, 0]), torch.ones(3, dtype=torch.bool))) == 0


def test_n_step_returns_run_over_each_rows_own_transitions_and_stop_at_its_end():
    open_ = OpenTransitions(2, (1,), (), torch.long, torch.device("cpu"))
    nstep = NStepRows(2, 2, None, 0.5)
    no, both = torch.zeros(2, dtype=torch.bool), torch.ones(2, dtype=torch.bool)
    stored = []

    def keep(done):
        out, discounts = nstep.add(done)
        stored.extend(zip(out.rows.tolist(), out.obs[:, 0].tolist(), out.rewards.tolist(), out.next_obs[:, 0].tolist(),
                          discounts.tolist(), out.terminated.tolist()))

    keep(open_.act(_obs(0, 10), torch.tensor([0, 0]), both))
    open_.observe(torch.tensor([1.0, 1.0]), no, no, _obs(0, 0))
    keep(open_.act(_obs(1, 11), torch.tensor([0, 0]), torch.tensor([True, False])))  # row 1 waits
    open_.observe(torch.tensor([2.0, 2.0]), no, no, _obs(0, 0))
    keep(open_.act(_obs(2, 12), torch.tensor([0, 0]), both))
    # row 0: its first two transitions make the 2-step one 0 -> 2 (1 + 0.5 * 2); row 1 has one transition so far
    assert stored == [(0, 0.0, 2.0, 2.0, 0.25, False)]
    keep(open_.observe(torch.tensor([4.0, 4.0]), torch.tensor([True, False]), no, _obs(9, 19)))
    # row 0 ends: 1 -> end (2 + 0.5 * 4) and 2 -> end (4, one step)
    assert stored[1:] == [(0, 1.0, 4.0, 9.0, 0.25, True), (0, 2.0, 4.0, 9.0, 0.5, True)]
    keep(open_.act(_obs(0, 13), torch.tensor([0, 0]), both))
    # row 1: 10 -> 12 summed its wait (1 + 2 = 3), then 12 -> 13 (4): 3 + 0.5 * 4
    assert stored[3:] == [(1, 10.0, 5.0, 13.0, 0.25, False)]
