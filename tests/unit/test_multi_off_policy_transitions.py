"""Multi-policy DQN / SAC's replay transitions: from an agent's step to its NEXT active step, rewards summed."""

import torch

from rlchain.algos.multi_off_policy.transitions import OpenTransitions


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
