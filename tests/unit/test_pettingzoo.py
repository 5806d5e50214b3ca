"""PettingZoo adapter, masked returns and minibatches, the multi_agent block and multi-policy PPO.

The env here is rlchain/envs/examples/pz_dying.py (PettingZoo's ParallelEnv API without importing
pettingzoo): agents that terminate early and one that appears later. The MPE / classic envs are
tried in tests/smoke/test_pettingzoo_configs.py and tests/learning/test_pettingzoo_learning.py.
"""

import copy
import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.algos.core.returns import gae, next_values_from_rollout
from rlchain.algos.core.storage import RolloutStorage
from rlchain.algos.multi_policy.masked import active_minibatches, masked_gae
from rlchain.config.errors import ConfigError
from rlchain.config.multi_agent import PolicyMapping
from rlchain.envs.backends.pettingzoo_env import PettingZooVecEnv, pettingzoo_env, resolve_env_module
from rlchain.runs import checkpoint as ckpt

DYING = {
    "params": {
        "seed": 3,
        "algo": {"name": "a2c_discrete"},
        "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [16]}},
        "config": {"name": "dying", "env_name": "pettingzoo", "device": "cpu", "num_actors": 4,
                   "env_config": {"env": "rlchain.envs.examples.pz_dying", "kwargs": {"runners": 2, "length": 6}},
                   "horizon_length": 12, "minibatch_size": 16, "mini_epochs": 2, "max_epochs": 3,
                   "print_stats": False, "save_best_after": 0,
                   "multi_agent": {"policies": {"runners": {}, "late": {"config": {"learning_rate": 1e-3}}},
                                   "policy_mapping": {"runner_*": "runners", "late_*": "late"}},
                   "player": {"games_num": 4}},
    }
}


def dying(tmp_path=None, **config):
    raw = copy.deepcopy(DYING)
    raw["params"]["config"].update(config)
    if tmp_path is not None:
        raw["params"]["config"]["train_dir"] = str(tmp_path)
    return raw


# ----- the adapter -------------------------------------------------------------------------
def test_agents_that_die_or_appear_later_are_inactive_and_end_once():
    env = pettingzoo_env(2, 0, env="rlchain.envs.examples.pz_dying", kwargs={"runners": 2, "length": 6})
    views = env.reset(seed=0)
    active, ends = [], []
    for _ in range(6):
        active.append({a: int(v.active[0]) for a, v in views.items()})
        result = env.step({a: np.zeros(2, dtype=np.int64) for a in env.agent_ids})
        ends.append({a: int(result.terminated[a][0]) for a in env.agent_ids})
        views = result.obs
    # runner_0 ends after 2 steps, runner_1 after 3; late_0 acts at steps 3-5 and ends at 5; then a new episode
    assert [s["runner_0"] for s in active] == [1, 1, 0, 0, 0, 1]
    assert [s["runner_1"] for s in active] == [1, 1, 1, 0, 0, 1]
    assert [s["late_0"] for s in active] == [0, 0, 1, 1, 1, 0]
    assert [s["runner_0"] for s in ends] == [0, 1, 0, 0, 0, 0]
    assert [s["late_0"] for s in ends] == [0, 0, 0, 0, 1, 0]
    assert env.pop_games() == 2 and env.pop_games() == 0  # both envs ended their episode once
    assert not views["late_0"].obs.any()  # an absent agent's observation is zeros, never a stale one


class OneHot:
    """A ParallelEnv whose one agent sees a Discrete(3) observation (2, then 1) and ends after 2 steps."""

    possible_agents = ["a"]

    def observation_space(self, agent):
        return gym.spaces.Discrete(3)

    def action_space(self, agent):
        return gym.spaces.Discrete(2)

    def reset(self, seed=None, options=None):
        self.agents, self.t = ["a"], 0
        return {"a": 2}, {"a": {}}

    def step(self, actions):
        self.t += 1
        done = self.t == 2
        if done:
            self.agents = []
        return {"a": 1}, {"a": 0.0}, {"a": done}, {"a": False}, {"a": {}}


def test_discrete_observations_are_one_hot_and_a_reset_env_says_so():
    env = PettingZooVecEnv(OneHot, 2, 0)
    assert env.observation_spaces["a"].shape == (3,)
    assert env.reset(seed=0)["a"].obs.tolist() == [[0, 0, 1], [0, 0, 1]]  # gymnasium's flatten, not the index
    first = env.step({"a": np.zeros(2, np.int64)})
    assert first.obs["a"].obs.tolist() == [[0, 1, 0], [0, 1, 0]] and not first.started.any()
    second = env.step({"a": np.zeros(2, np.int64)})
    assert second.started.all() and second.obs["a"].obs.tolist() == [[0, 0, 1], [0, 0, 1]]


def test_unknown_env_names_what_was_tried():
    with pytest.raises(ConfigError, match="params.config.env_config.env: cannot find PettingZoo env 'nope.x_v1'"):
        resolve_env_module("nope.x_v1")


def test_mpe_names_resolve_to_the_mpe2_package():
    pytest.importorskip("mpe2")
    assert resolve_env_module("mpe.simple_spread_v3").__name__ == "mpe2.simple_spread_v3"


# ----- masked returns and minibatches ----------------------------------------------------------
def test_masked_gae_with_every_step_active_is_gae():
    g = torch.Generator().manual_seed(0)
    t, n = 9, 4
    rewards, values, final = (torch.randn(t, n, 1, generator=g) for _ in range(3))
    last = torch.randn(n, 1, generator=g)
    dones = torch.rand(t, n, generator=g) < 0.3
    terminated = dones & (torch.rand(t, n, generator=g) < 0.5)
    adv, ret = masked_gae(rewards, values, final, last, torch.ones(t, n, dtype=torch.bool), terminated, dones,
                          0.9, 0.8)
    want, want_ret = gae(rewards, values, next_values_from_rollout(values, last, final, dones), terminated, dones,
                         0.9, 0.8)
    assert torch.allclose(adv, want, atol=1e-6) and torch.allclose(ret, want_ret, atol=1e-6)


def test_masked_gae_chains_over_gaps_and_sums_the_rewards_between_turns():
    # one row acting at t=0 and t=2 (t=1 is the other player's move), the game ends at t=3 (a loss it
    # does not act in): the move at t=2 gets r2 + r3 and a terminal; the move at t=0 chains to t=2
    rewards = torch.tensor([0.5, 0.25, 0.0, -1.0]).reshape(4, 1, 1)
    values = torch.tensor([0.1, 9.0, 0.3, 9.0]).reshape(4, 1, 1)
    active = torch.tensor([True, False, True, False]).reshape(4, 1)
    dones = torch.tensor([False, False, False, True]).reshape(4, 1)
    gamma, lam = 0.9, 0.5
    adv, ret = masked_gae(rewards, values, torch.zeros(4, 1, 1), torch.tensor([[7.0]]), active, dones, dones,
                          gamma, lam)
    a2 = (0.0 - 1.0) - 0.3  # rewards until its next move (none: the game ended), terminal
    a0 = (0.5 + 0.25) + gamma * 0.3 - 0.1 + gamma * lam * a2
    assert adv.flatten().tolist() == pytest.approx([a0, 0.0, a2, 0.0])
    assert ret.flatten().tolist() == pytest.approx([a0 + 0.1, 0.0, a2 + 0.3, 0.0])


def test_active_minibatches_hold_active_steps_only_each_once():
    storage = RolloutStorage(4, 3, (2,), torch.float32, (), torch.long, 2, 1, torch.device("cpu"))
    for t in range(4):
        storage.add(t, torch.full((3, 2), float(t)), torch.zeros(3, dtype=torch.long), torch.zeros(3),
                    torch.zeros(3, 1), torch.zeros(3, 2))
    active = torch.tensor([[1, 0, 1], [0, 0, 1], [1, 1, 0], [0, 0, 1]], dtype=torch.bool)
    seen = torch.cat([b.index for b in active_minibatches(storage, active, 2, torch.zeros(4, 3))])
    assert sorted(seen.tolist()) == active.reshape(-1).nonzero().squeeze(-1).tolist()
    batches = list(active_minibatches(storage, active, 2, torch.zeros(4, 3)))
    assert len(batches) == 3 and all(len(b.index) == 2 for b in batches)  # 6 active steps / minibatch 2


# ----- the multi_agent block -------------------------------------------------------------------
def test_policy_mapping_first_matching_glob_wins_and_unmapped_agents_are_an_error():
    mapping = PolicyMapping({"adversary_0": "boss", "adversary_*": "predator", "agent_*": "prey"},
                            ["boss", "predator", "prey"], "cfg.yaml")
    assert mapping.assign(["adversary_0", "adversary_1", "agent_0"]) == {
        "boss": ["adversary_0"], "predator": ["adversary_1"], "prey": ["agent_0"]}
    with pytest.raises(ConfigError, match=r"cfg.yaml: params.config.multi_agent.policy_mapping: agent 'leader_0' "
                                          r"matches no glob"):
        mapping.candidates("leader_0")


@pytest.mark.parametrize("change, match", [
    ({"policy_mapping": {"runner_*": "runner", "late_*": "late"}},
     r"policy_mapping.runner_\*: unknown policy 'runner' \(policies: runners, late\); did you mean 'runners'\?"),
    ({"policies_to_train": ["late", "ghost"]}, r"policies_to_train\[1\]: unknown policy 'ghost'"),
    ({"policies": {"runners": {"config": {"num_actors": 2}}, "late": {}}},
     r"policies.runners.config.num_actors: is a run-level key"),
    ({"policies": {"runners": {"config": {"learning_rat": 1e-3}}, "late": {}}},
     r"policies.runners.config.learning_rat: unknown key; did you mean 'learning_rate'\?"),
    ({"policy_mapping": {}}, r"policy_mapping: required with several policies"),
    ({"policy_mapping": {"runner_*": ["runners", "lat"], "late_*": "late"}},
     r"policy_mapping.runner_\*: unknown policy 'lat' \(policies: runners, late\); did you mean 'late'\?"),
    ({"policy_mapping": {"runner_*": [], "late_*": "late"}},
     r"policy_mapping.runner_\*: expected a policy name or a non-empty list of policy names, got \[\]"),
    ({"policy_mapping": {"runner_*": 3, "late_*": "late"}},
     r"policy_mapping.runner_\*: expected a policy name or a non-empty list of policy names, got 3"),
    ({"policy_mapping": {"runner_*": ["late", "late"], "late_*": "late"}},
     r"policy_mapping.runner_\*: names a policy twice \(late, late\)"),
    ({"snapshots": {"late": "runners"}}, r"snapshots.late: the snapshot 'late' must be frozen"),
])
def test_bad_multi_agent_blocks_are_one_line_errors(change, match):
    raw = dying()
    raw["params"]["config"]["multi_agent"].update(change)
    with pytest.raises(ConfigError, match=match):
        Runner().load(raw)


def test_a_policy_whose_network_does_not_fit_its_agents_spaces_is_named(tmp_path):
    raw = dying(tmp_path)
    raw["params"]["config"]["multi_agent"]["policies"]["late"] = {
        "model": {"name": "continuous_a2c_logstd"},
        "network": {"name": "actor_critic", "space": {"continuous": None}, "mlp": {"units": [8]}}}
    with pytest.raises(ConfigError, match=r"multi_agent.policies.late: network 'actor_critic' / model "
                                          r"'continuous_a2c_logstd' do not fit agents \['late_0'\] .*Discrete\(3\)"):
        Runner().load(raw).train()


@pytest.mark.parametrize("key,value", [("evaluation", {"interval": 2}), ("obs_normalizer_update", "minibatch")])
def test_single_policy_features_not_there_yet_are_errors(tmp_path, key, value):
    raw = dying(tmp_path)
    raw["params"]["config"][key] = value
    with pytest.raises(ConfigError, match=rf"params.config.{key}(.interval)?: is not supported with multi_agent"):
        Runner().load(raw).train()


def test_an_agent_no_glob_maps_is_an_error_before_training(tmp_path):
    raw = dying(tmp_path)
    raw["params"]["config"]["multi_agent"]["policy_mapping"] = {"runner_*": "runners"}
    with pytest.raises(ConfigError, match="agent 'late_0' matches no glob"):
        Runner().load(raw).train()
    assert not os.listdir(tmp_path)  # no run folder for a config that cannot train


# ----- multi-policy PPO: train, checkpoint, resume, play -------------------------------------
def test_two_policies_train_with_their_own_state_and_resume_exactly(tmp_path):
    runner = Runner().load(dying(tmp_path))
    result = runner.train()
    assert result.epoch == 3
    path = os.path.join(result.run_dir, "nn", "last_dying.pth")
    state = ckpt.load(path)
    assert {k.split(".")[0] for k in state["model"]} == {"runners", "late"}  # every policy's weights
    assert set(state["agent"]) == {"runners", "late"}  # and optimizer, lr
    assert state["agent"]["late"]["lr"] == pytest.approx(1e-3) and state["agent"]["runners"]["lr"] == 3e-4
    assert set(state["policy_episodes"]) == {"runners", "late"}
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    assert {"rewards/runners/step", "rewards/late/iter", "episode_lengths/late/time", "losses/late/a_loss",
            "losses/runners/c_loss", "info/runners/last_lr", "rewards/step"} <= tags
    assert "losses/a_loss" not in tags  # two policies: no unprefixed loss to mix them up in
    # resume: the learner state is exactly the checkpoint's
    from rlchain.algos.multi_policy.multi_policy import MultiPolicyPPO
    from rlchain.models.build import build_env, build_model
    from rlchain.runs.logging import TrainLogger
    from rlchain.training.loop import Loop

    params = runner.params
    env = build_env(params, 4, 3)
    model = build_model(params, env, torch.device("cpu"))
    trainer = Loop(params, MultiPolicyPPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 3,
                   runner.raw)
    trainer.restore(state, path)
    again = trainer.checkpoints.state_dict()
    for key, value in state["model"].items():
        assert torch.equal(again["model"][key], value), key
    for name in ("runners", "late"):
        assert again["agent"][name]["lr"] == state["agent"][name]["lr"]
        assert again["agent"][name]["optimizer"]["state"].keys() == state["agent"][name]["optimizer"]["state"].keys()
    assert (again["epoch"], again["frames"]) == (3, state["frames"])
    env.close()
    # a resumed run goes on to max_epochs
    resumed = Runner().load(dying(tmp_path, max_epochs=4)).train(checkpoint=path)
    assert resumed.epoch == 4
    played = Runner().load(dying()).play(path, quiet=True)
    assert played.games >= 4 and set(played.mean_rewards) == {"runners", "late"}


def test_inactive_steps_never_reach_the_storage_statistics(tmp_path):
    from rlchain.algos.multi_policy.multi_policy import MultiPolicyPPO
    from rlchain.models.build import build_env, build_model
    from rlchain.runs.logging import TrainLogger
    from rlchain.training.loop import Loop

    runner = Runner().load(dying(tmp_path))
    params = runner.params
    env = build_env(params, 4, 3)
    model = build_model(params, env, torch.device("cpu"))
    trainer = Loop(params, MultiPolicyPPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 3,
                   runner.raw).algorithm
    trainer.start()
    assert trainer.collect()
    late = trainer.learner("late")
    # late_0 acts at steps 2, 3, 4 of each 5-step episode: 3 of every 5 steps, in all 4 envs
    assert late.active.float().mean().item() == pytest.approx(3 / 5 * 10 / 12, abs=0.01)
    stats = trainer.update()
    assert {"losses/late/a_loss", "losses/runners/a_loss", "info/late/last_lr", "info/runners/kl"} <= set(stats)
    assert late.storage.returns[~late.active].abs().sum() == 0  # inactive steps carry no target
    # each late_0 episode lasts 3 of its own steps: the lengths count the agent's steps, not the env's
    assert set(late.tracker.finished_lengths) == {3}
    runners = trainer.learner("runners")
    assert sorted(set(runners.tracker.finished_lengths)) == [2, 3]
    env.close()


def test_frozen_policies_keep_their_weights(tmp_path):
    states = []
    for epochs in (1, 3):
        raw = dying(tmp_path / str(epochs), max_epochs=epochs)
        raw["params"]["config"]["multi_agent"]["policies_to_train"] = ["runners"]
        result = Runner().load(raw).train(seed=11)
        states.append(ckpt.load(os.path.join(result.run_dir, "nn", "last_dying.pth")))
    assert set(states[0]["agent"]) == {"runners"}  # a frozen policy has no optimizer
    late = [k for k in states[0]["model"] if k.startswith("late.")]
    assert late and all(torch.equal(states[0]["model"][k], states[1]["model"][k]) for k in late)
    runners = [k for k in states[0]["model"] if k.startswith("runners.a2c_network")]
    assert any(not torch.equal(states[0]["model"][k], states[1]["model"][k]) for k in runners)


class Const(torch.nn.Module):
    """A policy that always plays ``value``."""

    def __init__(self, value):
        super().__init__()
        self.value = torch.nn.Parameter(torch.tensor(float(value)))

    def act(self, obs, action_masks=None):
        return {"actions": self.value.detach().round().long().expand(obs.shape[0])}


def test_snapshot_refreshes_go_to_a_moving_window_of_envs_the_others_keep_theirs():
    from rlchain.algos.multi_policy.snapshots import SnapshotPool

    pool = SnapshotPool(Const(0), num_envs=4)
    obs = torch.zeros(8, 1)  # 2 agents x 4 envs, agent-major
    pool.refresh(Const(1), [0, 1, 2, 3])
    assert pool.act(obs, 2, None).tolist() == [1] * 8 and not pool.older
    pool.refresh(Const(2), [0, 1])
    assert pool.act(obs, 2, None).tolist() == [2, 2, 1, 1, 2, 2, 1, 1]
    pool.refresh(Const(3), [2, 3])
    assert pool.act(obs, 2, None).tolist() == [2, 2, 3, 3, 2, 2, 3, 3]
    assert len(pool.older) == 1  # the snapshot no env plays any more is dropped


def test_an_aec_env_that_says_it_is_parallelizable_goes_through_aec_to_parallel(monkeypatch):
    import sys
    import types

    mpe = pytest.importorskip("mpe2.simple_spread_v3")
    module = types.ModuleType("aec_only_spread")
    module.env = mpe.env  # the AEC env alone (no parallel_env): is_parallelizable in its metadata
    monkeypatch.setitem(sys.modules, "aec_only_spread", module)
    from rlchain.envs.backends.pettingzoo_env import env_maker

    make, turn_based = env_maker("aec_only_spread", {"N": 2, "max_cycles": 3})
    assert not turn_based and type(make()).__name__ == "aec_to_parallel_wrapper"
    env = pettingzoo_env(2, 0, env="aec_only_spread", kwargs={"N": 2, "max_cycles": 3})
    views = env.reset(seed=0)
    assert all(v.active.all() for v in views.values())  # every agent acts every step
    for _ in range(3):
        result = env.step({a: np.zeros(2, dtype=np.int64) for a in env.agent_ids})
    assert all(result.truncated[a].all() for a in env.agent_ids) and env.pop_games() == 2


def test_turn_based_games_give_the_mover_its_legal_moves_and_the_waiting_player_nothing_to_do():
    pytest.importorskip("pettingzoo.classic")
    env = pettingzoo_env(3, 0, env="classic.connect_four_v3")
    rng = np.random.default_rng(0)
    views = env.reset(seed=0)
    games = 0
    for _ in range(120):
        mover, waiting = views["player_0"], views["player_1"]
        assert (mover.active ^ waiting.active).all()  # exactly one player moves in each env
        for view in views.values():
            assert view.mask[~view.active].all()  # a waiting player's mask is all True (never empty)
            for i in np.flatnonzero(view.active):
                board = view.obs[i].reshape(6, 7, 2)
                assert view.mask[i].tolist() == (board[0].sum(-1) == 0).tolist()  # a column with room
        actions = {a: np.array([rng.choice(np.flatnonzero(m)) for m in v.mask]) for a, v in views.items()}
        result = env.step(actions)
        # a game ends for both players at once, one wins (+1) and the other loses (-1), or a draw
        assert (result.terminated["player_0"] == result.terminated["player_1"]).all()
        ended = result.terminated["player_0"]
        assert (result.reward["player_0"][ended] + result.reward["player_1"][ended] == 0).all()
        games += int(ended.sum())
        views = result.obs
    assert games >= 5
