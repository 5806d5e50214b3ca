"""RLlib's MultiAgentEnv through the face (rlchain/rllib/multi_agent.py): the dict-of-agents API seen as
PettingZoo's parallel API (who acts, who waits, who leaves, "__all__"), the policy mapping, and a short
multi-policy training with RLlib's multi-agent results."""

import gymnasium as gym
import numpy as np
import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.env.multi_agent_env import MultiAgentEnv, make_multi_agent
from rlchain.rllib.multi_agent import EpisodeLog, ParallelView, agent_policies


class TakeTurns(MultiAgentEnv):
    """Two players (ids 0 and 1) move in turn; only the mover gets an observation. A move scores +1 for the
    mover when it names the target it sees; after 4 moves the game ends with "__all__" and player 1 gets a
    bonus of 10 it did not act for."""

    def __init__(self, config=None):
        super().__init__()
        self.agents = self.possible_agents = [0, 1]
        self.observation_spaces = {a: gym.spaces.Box(0.0, 1.0, (2,), np.float32) for a in self.agents}
        self.action_spaces = {a: gym.spaces.Discrete(2) for a in self.agents}
        self.received = []

    def _obs(self, agent):
        return {agent: np.eye(2, dtype=np.float32)[self.moves % 2]}

    def reset(self, *, seed=None, options=None):
        self.moves, self.mover = 0, 0
        return self._obs(0), {}

    def step(self, action_dict):
        self.received.append(dict(action_dict))
        assert list(action_dict) == [self.mover], action_dict  # only the mover's action is sent
        reward = {self.mover: float(action_dict[self.mover] == self.moves % 2)}
        self.moves += 1
        self.mover = 1 - self.mover
        if self.moves == 4:
            reward[1] = reward.get(1, 0.0) + 10.0
            return {}, reward, {"__all__": True}, {"__all__": False}, {}
        return self._obs(self.mover), reward, {"__all__": False}, {"__all__": False}, {}


class Arrivals(MultiAgentEnv):
    """'early' is there from the start and leaves (terminated) after 2 steps; 'late' appears at step 1; the
    episode is truncated for everyone left after 3 steps."""

    def __init__(self, config=None):
        super().__init__()
        self.possible_agents = ["early", "late"]
        self.observation_space = gym.spaces.Box(0.0, 1.0, (1,), np.float32)  # one space shared by all
        self.action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        self.t = 0
        return {"early": np.zeros(1, np.float32)}, {}

    def step(self, action_dict):
        self.t += 1
        obs, rew, term = {}, {a: 1.0 for a in action_dict}, {"__all__": False}
        if self.t < 2:
            obs["early"] = np.zeros(1, np.float32)
        elif self.t == 2:
            obs["early"], term["early"] = np.ones(1, np.float32), True  # its final observation
        if self.t >= 1:
            obs["late"] = np.zeros(1, np.float32)
        return obs, rew, term, {"__all__": self.t >= 3}, {}


def test_turn_based_env_sends_only_the_movers_action_and_ends_everyone_on_all():
    log = EpisodeLog()
    env = TakeTurns()
    view = ParallelView(env, [0, 1], log)
    assert view.possible_agents == ["0", "1"]
    obs, _ = view.reset()
    assert list(obs) == ["0"] and view.agents == ["0"]
    for move in range(4):
        mover = str(move % 2)
        obs, rew, term, trunc, _ = view.step({"0": 1 - move % 2 if move % 2 == 0 else 1, "1": 1})
        assert env.received[-1] == {move % 2: env.received[-1][move % 2]}  # the waiting player's row is dropped
        assert mover in rew
    # "__all__" ends both players: each gets its own terminated flag, nobody is left, the episode is logged
    assert term == {"0": True, "1": True} and trunc == {"0": False, "1": False}
    assert view.agents == [] and log.finished == 1
    assert log.lengths[0] == 4 and log.agent_returns["1"][0] >= 10.0
    assert log.returns[0] == pytest.approx(sum(r[0] for r in log.agent_returns.values()))


def test_agents_that_arrive_and_leave_mid_episode():
    view = ParallelView(Arrivals(), ["early", "late"])
    assert view.observation_space("late") == gym.spaces.Box(0.0, 1.0, (1,), np.float32)
    obs, _ = view.reset()
    assert view.agents == ["early"]
    obs, _, term, trunc, _ = view.step({"early": 0, "late": 0})
    assert set(view.agents) == {"early", "late"} and set(obs) == {"early", "late"}
    obs, _, term, trunc, _ = view.step({"early": 0, "late": 0})
    assert term["early"] and view.agents == ["late"]  # it left with its final observation
    obs, _, term, trunc, _ = view.step({"early": 0, "late": 0})
    assert trunc == {"late": True} and not term.get("late") and view.agents == []


def test_policy_mapping_is_asked_per_agent_and_gives_the_policies_each_may_play():
    config = PPOConfig().multi_agent(policies={"p0", "p1"},
                                     policy_mapping_fn=lambda aid, episode, **kw: f"p{aid}")
    assert agent_policies(config, [0, 1], ["p0", "p1"]) == {0: ["p0"], 1: ["p1"]}
    random_sides = PPOConfig().multi_agent(policies={"p0", "p1"},
                                           policy_mapping_fn=lambda aid, ep, **kw: "p0" if ep.id_[-1] == "0" else "p1")
    assert agent_policies(random_sides, [0, 1], ["p0", "p1"]) == {0: ["p0", "p1"], 1: ["p0", "p1"]}
    wrong = PPOConfig().multi_agent(policies={"p0"}, policy_mapping_fn=lambda aid, ep, **kw: "q")
    with pytest.raises(ConfigError, match="maps agent 0 to 'q', not one of the policies"):
        agent_policies(wrong, [0], ["p0"])


def test_make_multi_agent_stacks_copies_of_a_single_agent_env():
    env = make_multi_agent("CartPole-v1")({"num_agents": 3})
    obs, _ = env.reset(seed=0)
    assert sorted(obs) == [0, 1, 2] and env.get_action_space(2) == gym.spaces.Discrete(2)
    obs, rew, term, trunc, _ = env.step({0: 0, 1: 1, 2: 0})
    assert rew == {0: 1.0, 1: 1.0, 2: 1.0} and term["__all__"] is False


def test_policies_need_a_multi_agent_env(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = PPOConfig().environment("CartPole-v1").multi_agent(policies={"a", "b"})
    with pytest.raises(ConfigError, match="not a MultiAgentEnv: policies need one") as info:
        config.build_algo()
    assert "\n" not in str(info.value)


def test_two_policies_train_on_a_turn_based_multi_agent_env(tmp_path, monkeypatch):
    """Each player its own policy: RLlib's multi-agent results (returns summed over agents, a learner per
    policy), the modules by policy id, evaluation, and a checkpoint that restores."""
    import torch

    monkeypatch.chdir(tmp_path)
    config = (PPOConfig().environment(TakeTurns).env_runners(num_env_runners=2).debugging(seed=1)
              .training(train_batch_size=64, minibatch_size=16, num_epochs=2)
              .multi_agent(policies={"first", "second"}, policy_mapping_fn=lambda aid, *a, **kw: ["first",
                                                                                                  "second"][aid],
                           policies_to_train=["first"]))
    algo = config.build_algo()
    try:
        before = {k: v.clone() for k, v in algo.get_module("second").state_dict().items()}
        result = algo.train()
        runners = result["env_runners"]
        assert runners["episode_len_mean"] == 4 and runners["num_episodes_lifetime"] >= 16
        assert runners["episode_return_mean"] >= 10.0  # player 1's bonus is in the episode's sum
        assert runners["module_episode_returns_mean"]["second"] >= 10.0
        assert set(runners["agent_episode_returns_mean"]) == {0, 1}
        assert set(result["learners"]) == {"first", "__all_modules__"}  # 'second' is frozen
        assert np.isfinite(result["learners"]["first"]["policy_loss"])
        last = algo._stepper.context.algorithm.agent.agents["first"].last_minibatch_stats  # RLlib's window=1
        assert result["learners"]["first"]["policy_loss"] == last["a_loss"]
        assert result["learners"]["first"]["mean_kl_loss"] == last["kl"]
        after = algo.get_module("second").state_dict()
        assert all(torch.equal(before[k], after[k]) for k in before)
        out = algo.get_module("first").forward_inference({"obs": torch.eye(2)})["action_dist_inputs"]
        assert out.shape == (2, 2)
        with pytest.raises(KeyError, match="the policies are"):
            algo.get_module("third")
        games = algo.evaluate()["env_runners"]
        assert games["num_episodes"] >= 10 and games["episode_len_mean"] == 4
        path = algo.save_to_path(str(tmp_path / "ckpt"))
        weights = algo.get_module("first").state_dict()
        algo.train()
        algo.restore_from_path(path)
        assert all(torch.equal(weights[k], v) for k, v in algo.get_module("first").state_dict().items())
    finally:
        algo.stop()


def test_a_frozen_module_that_only_acts_plays_beside_a_trained_policy(tmp_path, monkeypatch):
    """RLlib's heuristic-opponent pattern: a weightless RLModule returning 'actions' (no compute_values), left out
    of policies_to_train, via MultiRLModuleSpec; PolicySpec() entries; the trained one's own default module."""
    import torch

    from rlchain.rllib.core.columns import Columns
    from rlchain.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from rlchain.rllib.core.rl_module.rl_module import RLModule, RLModuleSpec
    from rlchain.rllib.policy.policy import PolicySpec

    class AlwaysOne(RLModule):
        def _forward(self, batch, **kwargs):
            return {Columns.ACTIONS: np.ones(len(batch[Columns.OBS]), np.int64)}

    monkeypatch.chdir(tmp_path)
    specs = MultiRLModuleSpec(rl_module_specs={"learner": RLModuleSpec(),
                                               "fixed": RLModuleSpec(module_class=AlwaysOne)})
    config = (PPOConfig().environment(TakeTurns).env_runners(num_env_runners=1)
              .training(train_batch_size=32, minibatch_size=16, num_epochs=1)
              .multi_agent(policies={"learner": PolicySpec(), "fixed": PolicySpec()},
                           policy_mapping_fn=lambda aid, *a, **kw: ["learner", "fixed"][aid],
                           policies_to_train=["learner"])
              .rl_module(rl_module_spec=specs))
    algo = config.build_algo()
    try:
        algo.train()
        obs = torch.eye(2)
        assert algo.get_module("fixed").forward_inference({"obs": obs})["action_dist_inputs"].argmax(-1).tolist() \
            == [1, 1]
        assert algo.compute_single_action(np.eye(2, dtype=np.float32)[0], policy_id="fixed") == 1
    finally:
        algo.stop()
    trained = config.copy().multi_agent(policies_to_train=None)
    with pytest.raises(ConfigError, match="AlwaysOne has no compute_values.*left out of policies_to_train") as info:
        trained.build_algo()
    assert "\n" not in str(info.value)
    overrides = config.copy().multi_agent(policies={"learner": PolicySpec(config={"lr": 0.1}), "fixed": None})
    with pytest.raises(ConfigError, match="per-policy config overrides are not mapped"):
        overrides.build_algo()


def _fixed(action):
    from rlchain.rllib.core.columns import Columns
    from rlchain.rllib.core.rl_module.rl_module import RLModule

    class Fixed(RLModule):
        def _forward(self, batch, **kwargs):
            return {Columns.ACTIONS: np.full(len(batch[Columns.OBS]), action, np.int64)}

    return Fixed


def _opponents(mapping_fn):
    from rlchain.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from rlchain.rllib.core.rl_module.rl_module import RLModuleSpec

    specs = MultiRLModuleSpec(rl_module_specs={"learner": RLModuleSpec(), "zero": RLModuleSpec(module_class=_fixed(0)),
                                               "one": RLModuleSpec(module_class=_fixed(1))})
    return (PPOConfig().environment(TakeTurns).env_runners(num_env_runners=1, num_envs_per_env_runner=2)
            .training(train_batch_size=64, minibatch_size=32, num_epochs=1)
            .multi_agent(policies={"learner", "zero", "one"}, policy_mapping_fn=mapping_fn,
                         policies_to_train=["learner"])
            .rl_module(rl_module_spec=specs))


def test_a_random_opponent_per_episode_plays_whole_episodes(tmp_path, monkeypatch):
    """RLlib's heuristic-vs-learned pattern: player 1 is 'zero' or 'one' by episode. 'one' names player 1's
    target on both of its moves (12 with the bonus), 'zero' never does (10): an episode that mixed them, or a
    return counted for the wrong module, would show between."""
    monkeypatch.chdir(tmp_path)
    config = _opponents(lambda aid, ep, **kw: "learner" if aid == 0 else ["zero", "one"][int(ep.id_[8:]) % 2])
    algo = config.build_algo()
    try:
        modules = algo.train()["env_runners"]["module_episode_returns_mean"]
        assert modules["one"] == 12.0 and modules["zero"] == 10.0 and "learner" in modules
        played = algo.evaluate()["env_runners"]["module_episode_returns_mean"]
        assert played["one"] == 12.0 and played["zero"] == 10.0
    finally:
        algo.stop()


def test_an_answer_the_probe_episodes_never_gave_is_one_line(tmp_path, monkeypatch):
    from rlchain.rllib.multi_agent import PROBES

    monkeypatch.chdir(tmp_path)
    late = _opponents(lambda aid, ep, **kw: "learner" if aid == 0 or int(ep.id_[8:]) >= PROBES else
                      ["zero", "one"][int(ep.id_[8:]) % 2])
    with pytest.raises(Exception, match=rf"policy_mapping_fn: maps agent 1 to 'learner' in episode_{PROBES}, which "
                                        rf"{PROBES} episodes asked up front never did") as info:
        algo = late.build_algo()
        try:
            algo.train()
        finally:
            algo.stop()
    assert "\n" not in str(info.value)


def test_agent_groups_are_refused_in_one_line():
    # multi_agent/two_step_game_with_grouped_agents.py: env.with_agent_groups(...) (a traceback before)
    from rlchain.rllib.__main__ import explain
    from rlchain.rllib.env.multi_agent_env import MultiAgentEnv
    from rlchain.rllib.face_error import FaceNotOffered

    class Two(MultiAgentEnv):
        pass

    with pytest.raises(FaceNotOffered) as info:
        Two().with_agent_groups({"group_1": [0, 1]})
    line = explain(info.value)
    assert line is not None and "\n" not in line and "with_agent_groups is not offered" in line
