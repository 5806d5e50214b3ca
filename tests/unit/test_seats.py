"""Per-episode policy mapping (rlchain.models.seats): slots, owned rows, draws; multi-policy PPO with a listed agent.

The env is rlchain/envs/examples/pz_dying.py (2 runners that end after 2 and 3 steps, late_0 from step 2 to 5:
5-step episodes); ``runner_1`` is played by ``runners`` or ``late``, one of them per episode of each env.
"""

from types import SimpleNamespace

import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.algos.multi_policy.policies import PolicyLearner
from rlchain.config.errors import ConfigError
from rlchain.config.multi_agent import PolicyMapping
from rlchain.models.seats import Seats
from tests.unit.test_pettingzoo import dying

LISTED = {"runner_0": "runners", "runner_1": ["runners", "late"], "late_*": "late"}


def test_a_listed_agent_has_a_slot_in_each_of_its_policies():
    mapping = PolicyMapping(LISTED, ["runners", "late"])
    assert mapping.assign(["runner_0", "runner_1", "late_0"]) == {"runners": ["runner_0", "runner_1"],
                                                                   "late": ["runner_1", "late_0"]}
    assert mapping.candidates("runner_1") == ["runners", "late"]


def test_owned_rows_follow_each_envs_draw_and_static_policies_own_all():
    seats = Seats({"a": ["p"], "b": ["p", "q"], "c": ["q"]}, num_envs=4, seed=0)
    assert seats.dynamic and seats.drawn == ["b"]
    seats.draw(np.arange(4))
    p, q = seats.owned("p", ["a", "b"]), seats.owned("q", ["b", "c"])
    assert p[:4].all() and q[4:].all()  # a plays p, c plays q in every env
    assert (p[4:] ^ q[:4]).all()  # b's row of env e is p's or q's, never both
    assert [seats.policy_of("b", e) for e in range(4)] == ["p" if p[4 + e] else "q" for e in range(4)]
    static = Seats({"a": ["p"]}, num_envs=4, seed=0)
    assert not static.dynamic and static.owned("p", ["a"]) is None  # nothing to mask


def test_draws_are_per_env_seeded_uniform_and_the_env_may_name_the_policy():
    seats = Seats({"b": ["p", "q"]}, num_envs=2, seed=1)
    seats.draw(np.arange(2))
    before = seats.choice["b"].copy()
    counts = np.zeros(2)
    for _ in range(200):
        seats.draw(np.array([1]))  # only env 1 starts an episode
        assert seats.choice["b"][0] == before[0]
        counts[seats.choice["b"][1]] += 1
    assert counts.min() > 70  # both policies, about half each
    again = Seats({"b": ["p", "q"]}, num_envs=2, seed=1)
    again.draw(np.arange(2))
    assert (again.choice["b"] == before).all()
    seats.draw(np.arange(2), named=lambda i: {"b": "q"} if i == 0 else None)
    assert seats.policy_of("b", 0) == "q"
    with pytest.raises(ConfigError, match=r"policy_mapping: the env chose policy 'r' for agent 'b', which may play "
                                          r"only p, q"):
        seats.draw(np.arange(1), named=lambda i: {"b": "r"})


def test_the_generator_state_round_trips():
    seats = Seats({"b": ["p", "q", "r"]}, num_envs=8, seed=2)
    state = seats.state_dict()
    seats.draw(np.arange(8))
    first = seats.choice["b"].copy()
    other = Seats({"b": ["p", "q", "r"]}, num_envs=8, seed=99)
    other.load_state_dict(state)
    other.draw(np.arange(8))
    assert (other.choice["b"] == first).all()


def test_each_env_row_takes_the_action_of_the_policy_that_plays_it():
    learner = SimpleNamespace(num_envs=3, agents=["a", "b"])
    actions = {}
    PolicyLearner.put(learner, actions, np.array([0, 0, 0, 1, 1, 1]), torch.tensor([1, 1, 1, 1, 0, 1]).bool())
    other = SimpleNamespace(num_envs=3, agents=["b"])
    PolicyLearner.put(other, actions, np.array([7, 7, 7]), torch.tensor([0, 1, 0]).bool())
    assert actions["a"].tolist() == [0, 0, 0] and actions["b"].tolist() == [1, 7, 1]


def _trainer(tmp_path):
    from rlchain.algos.multi_policy.multi_policy import MultiPolicyPPO
    from rlchain.models.build import build_env, build_model
    from rlchain.runs.logging import TrainLogger
    from rlchain.training.loop import Loop

    raw = dying(tmp_path)
    raw["params"]["config"]["multi_agent"]["policy_mapping"] = LISTED
    runner = Runner().load(raw)
    env = build_env(runner.params, 4, 3)
    model = build_model(runner.params, env, torch.device("cpu"))
    loop = Loop(runner.params, MultiPolicyPPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 3,
                runner.raw)
    return loop.algorithm, env


def test_a_listed_agent_plays_one_policy_per_episode_and_only_its_steps_count(tmp_path):
    trainer, env = _trainer(tmp_path)
    trainer.start()
    assert trainer.collect()
    runners, late = trainer.learner("runners"), trainer.learner("late")
    assert runners.agents == ["runner_0", "runner_1"] and late.agents == ["runner_1", "late_0"]
    mine, theirs = runners.active[:, 4:], late.active[:, :4]  # runner_1's rows (4 envs) in each policy
    assert not (mine & theirs).any()  # never both
    # runner_1 acts at steps 0-2 of every 5-step episode: each of those steps is in exactly one policy
    acts = torch.tensor([t % 5 < 3 for t in range(12)]).unsqueeze(-1).expand(12, 4)
    assert torch.equal(mine | theirs, acts)
    for e in range(4):  # the same policy for the whole of an episode, both over the rollout
        for start in (0, 5):
            steps = mine[start:start + 3, e]
            assert steps.all() or not steps.any()
    assert mine.any() and theirs.any()
    # each runner_1 episode counted once, by the policy that played it (3 of its own steps each)
    games = runners.tracker.games + late.tracker.games
    assert games == 4 * 3 + 4 * 2 + 4 * 2  # in 12 steps of 4 envs: runner_0 ends 3 times, runner_1 and late_0 twice
    assert set(late.tracker.finished_lengths) == {3}
    stats = trainer.update()
    assert {"losses/late/a_loss", "losses/runners/a_loss"} <= set(stats)
    assert late.storage.returns[~late.active].abs().sum() == 0
    env.close()


def test_a_config_with_a_listed_agent_trains_and_plays(tmp_path):
    raw = dying(tmp_path)
    raw["params"]["config"]["multi_agent"]["policy_mapping"] = LISTED
    result = Runner().load(raw).train()
    assert result.epoch == 3
    played = Runner().load(raw).play(f"{result.run_dir}/nn/last_dying.pth", quiet=True)
    assert played.games >= 4 and set(played.mean_rewards) == {"runners", "late"}
    assert len(played.rewards["runners"]) + len(played.rewards["late"]) >= 3 * played.games  # 3 agents a game
