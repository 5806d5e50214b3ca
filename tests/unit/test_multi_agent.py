"""Multi-agent envs flattened into the batch: shapes, row layout, dones, final obs, per-agent stats."""

import copy
import os

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.algos.base.episodes import EpisodeTracker
from rlchain.algos.ppo.ppo import PPO
from rlchain.config.errors import ConfigError
from rlchain.config.load import parse_params
from rlchain.envs.backends.gymnasium_env import GymnasiumVecEnv
from rlchain.envs.examples.cooperative import CooperativeEnv, nearest_flag_policy
from rlchain.envs.factory import make_vec_env
from rlchain.envs.wrappers.multi_agent import MultiAgentVecEnv, make_multi_agent_env
from rlchain.models.build import build_env, build_model
from rlchain.runs.logging import TrainLogger
from rlchain.training.loop import Loop
from tests.conftest import BASE, CONFIGS


class Counting:
    """3 agents; agent j gets reward j + 1 per step; obs = [agent, step, env tag]; ends after
    ``length`` steps (terminated), or with ``rl_games_api`` as a time-out through info['time_outs']."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (3,), np.float32)
    action_space = gym.spaces.Discrete(2)

    def __init__(self, tag: int = 0, length: int = 3, rl_games_api: bool = False, split_done: bool = False):
        self.tag, self.length, self.rl_games_api, self.split_done = tag, length, rl_games_api, split_done
        self.t = 0
        self.actions = []

    def get_number_of_agents(self):
        return 3

    def _obs(self):
        return np.array([[j, self.t, self.tag] for j in range(3)], dtype=np.float32)

    def reset(self, seed=None):
        self.t = 0
        return self._obs() if self.rl_games_api else (self._obs(), {})

    def step(self, actions):
        self.actions.append(np.asarray(actions).copy())
        self.t += 1
        done = self.t >= self.length
        rewards = np.array([1.0, 2.0, 3.0], dtype=np.float32)
        if self.rl_games_api:
            return self._obs(), rewards, done, {"time_outs": done}
        if self.split_done:
            return self._obs(), rewards, np.array([done, False, done]), False, {}
        return self._obs(), rewards, done, False, {}


def test_rows_are_env_major_and_actions_reach_their_agent():
    envs = [Counting(tag=i) for i in range(2)]
    vec = MultiAgentVecEnv(envs)
    assert (vec.num_envs, vec.num_agents, vec.num_actors, vec.get_number_of_agents()) == (6, 3, 2, 3)
    obs = vec.reset(seed=0)
    assert obs.shape == (6, 3) and obs.dtype == np.float32
    assert obs[:, 0].tolist() == [0, 1, 2, 0, 1, 2]  # agent index
    assert obs[:, 2].tolist() == [0, 0, 0, 1, 1, 1]  # env index
    vec.step(np.array([1, 0, 1, 0, 0, 1]))
    assert envs[0].actions[0].tolist() == [1, 0, 1] and envs[1].actions[0].tolist() == [0, 0, 1]


def test_dones_broadcast_final_obs_and_per_agent_episode_stats():
    vec = MultiAgentVecEnv([Counting(tag=i, length=3 + i) for i in range(2)])
    tracker = EpisodeTracker(vec.num_envs, 100, torch.device("cpu"))
    vec.reset(seed=0)
    for _ in range(3):
        result = vec.step(np.zeros(6, dtype=np.int64))
        assert result.reward.tolist() == [1, 2, 3, 1, 2, 3]
        tracker.step(torch.as_tensor(result.reward), torch.as_tensor(result.terminated | result.truncated))
    # env 0 ended at step 3 on all its agents; env 1 (length 4) did not
    assert result.terminated.tolist() == [True] * 3 + [False] * 3
    assert not result.truncated.any()
    assert result.final_obs[:3, 1].tolist() == [3, 3, 3]  # each agent's last obs of the episode
    assert result.obs[:3, 1].tolist() == [0, 0, 0]  # already the next episode's first obs
    assert result.obs[3:, 1].tolist() == [3, 3, 3]
    assert sorted(tracker.finished_returns) == [3.0, 6.0, 9.0]  # one episode per agent, its own reward
    assert tracker.games == 3


def test_rl_games_step_api_and_time_outs():
    vec = MultiAgentVecEnv([Counting(length=2, rl_games_api=True)])
    assert vec.reset().shape == (3, 3)
    vec.step(np.zeros(3))
    result = vec.step(np.zeros(3))
    assert result.truncated.all() and not result.terminated.any()


def test_agents_of_one_env_must_end_together():
    vec = MultiAgentVecEnv([Counting(), Counting(length=1, split_done=True)])
    vec.reset()
    with pytest.raises(ValueError, match="env 1: agents of one env must end together"):
        vec.step(np.zeros(6))


def test_max_episode_steps_truncates():
    vec = MultiAgentVecEnv([Counting(length=100)], max_episode_steps=2)
    vec.reset()
    assert not vec.step(np.zeros(3)).truncated.any()
    result = vec.step(np.zeros(3))
    assert result.truncated.all() and not result.terminated.any()
    assert result.obs[:, 1].tolist() == [0, 0, 0]


class DictObs(Counting):
    """2 agents with Dict observations: rl_games' central-value layout or any other keys."""

    def __init__(self, keys=("obs", "state"), **kwargs):
        super().__init__(**kwargs)
        self.keys = keys
        self.observation_space = gym.spaces.Dict({keys[0]: gym.spaces.Box(-9, 9, (2,), np.float32),
                                                  keys[1]: gym.spaces.Box(-9, 9, (3,), np.float32)})
        self.opponents, self.scores = [], [1.0, 0.0]

    def get_number_of_agents(self):
        return 2

    def _obs(self):
        return {self.keys[0]: np.array([[1, 2], [3, 4]], np.float32) + self.tag,
                self.keys[1]: np.array([[5, 6, 7], [8, 9, 0]], np.float32)}

    def step(self, actions):
        obs, *_ = super().step(actions)
        return self._obs(), np.zeros(2, np.float32), False, False, {}

    def set_opponent(self, policy):
        self.opponents.append(policy)

    def pop_scores(self):
        out, self.scores = self.scores, []
        return out


def test_dict_observations_per_agent():
    vec = MultiAgentVecEnv([DictObs(tag=0), DictObs(tag=10)])
    assert vec.observation_space.obs_size == 2 and vec.observation_space.state_size == 3  # an ObsStateBox
    obs = vec.reset()
    assert obs.shape == (4, 5)
    assert obs[1].tolist() == [3, 4, 8, 9, 0] and obs[2].tolist() == [11, 12, 5, 6, 7]  # [obs | state]
    flat = MultiAgentVecEnv([DictObs(keys=("a", "b"))])
    assert flat.observation_space.shape == (5,)
    assert flat.step(np.zeros(2)).obs.tolist() == [[1, 2, 5, 6, 7], [3, 4, 8, 9, 0]]


def test_self_play_methods_reach_the_envs():
    envs = [DictObs(), DictObs(), DictObs()]
    vec = MultiAgentVecEnv(envs)
    vec.set_opponent("p1", [0, 2])
    vec.set_opponent("p2")
    assert [e.opponents for e in envs] == [["p1", "p2"], ["p2"], ["p1", "p2"]]
    assert vec.pop_scores().tolist() == [1, 0, 1, 0, 1, 0] and vec.pop_scores().size == 0


def test_factory_builds_the_adapter_for_multi_agent_ids_only():
    env = make_vec_env("TestCooperativeEnv-v0", {"length": 6}, 4, 0, None)
    try:
        assert isinstance(env, MultiAgentVecEnv)
        assert env.num_envs == 8 and env.envs[0].length == 6 and env.max_episode_steps == 20
        obs = env.reset(seed=3)
        assert obs.shape == (8, 6)
        direct = CooperativeEnv(length=6)
        for i in range(4):  # env i seeded with seed + i, its two agents in rows 2i, 2i + 1
            np.testing.assert_allclose(obs[2 * i:2 * i + 2], direct.reset(seed=3 + i)[0])
    finally:
        env.close()
    assert make_multi_agent_env("CartPole-v1", {}, 2, 0, "auto") is None
    cartpole = make_vec_env("CartPole-v1", {}, 2, 0, None)
    assert isinstance(cartpole, GymnasiumVecEnv)
    cartpole.close()
    with pytest.raises(ConfigError, match="must be auto or sync, not async: .* multi-agent or multi-reward env"):
        make_vec_env("TestCooperativeEnv-v0", {}, 2, 0, "async")


def test_cooperative_needs_coordination():
    """Walking to one's own nearest flag meets the partner only part of the time; both on one flag pays."""
    env = CooperativeEnv()
    met = 0
    for seed in range(300):
        obs, _ = env.reset(seed=seed)
        for _ in range(20):
            obs, reward, terminated, _, _ = env.step(nearest_flag_policy(obs))
            if terminated:
                assert reward.tolist() == [1.0, 1.0]
                met += 1
                break
    assert 0.4 < met / 300 < 0.75
    env.reset(seed=0)
    env.pos[:] = env.flags  # both on flags, but not the same one: no reward
    _, reward, terminated, _, _ = env.step(np.array([1, 1]))
    assert not terminated and np.allclose(reward, [-0.01, -0.01])


def _cooperative_config(**changes):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update(env_name="TestCooperativeEnv-v0", **changes)
    return raw


def _trainer(raw):
    params = parse_params(raw, "<test>")
    env = build_env(params, params.config.num_actors, 0)
    model = build_model(params, env, torch.device("cpu"))
    return Loop(params, PPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 0, raw)


def test_minibatch_is_checked_against_the_batch_with_agents():
    # 4 actors * 8 steps = 32 env steps; the cooperative env has 2 agents: a batch of 64 rows
    trainer = _trainer(_cooperative_config(minibatch_size=64))
    assert trainer.ctx.num_envs == 8 and trainer.algorithm.storage.obs.shape[:2] == (8, 8)
    trainer.env.close()
    with pytest.raises(ConfigError, match=r"batch num_actors\*horizon_length\*agents \(2 per env\) = 64 is not "
                                          r"divisible by minibatch_size 48"):
        _trainer(_cooperative_config(minibatch_size=48))
    single = copy.deepcopy(BASE)
    single["params"]["config"]["minibatch_size"] = 64
    parse_params(copy.deepcopy(single), "<test>")  # may fit a multi-agent env: accepted at load time
    with pytest.raises(ConfigError, match="params.config.minibatch_size: minibatch_size 64 is larger than the batch"):
        _trainer(single)


@pytest.mark.smoke
def test_cooperative_config_trains_and_plays(tmp_path):
    runner = Runner().load(os.path.join(CONFIGS, "ppo_test_cooperative.yaml"),
                           [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=2",
                            "params.config.print_stats=false"])
    result = runner.train()
    assert result.epoch == 2 and np.isfinite(result.mean_reward)
    played = runner.play(os.path.join(result.run_dir, "nn", "last_cooperative.pth"), games=6, quiet=True)
    assert played.games == 6  # per-agent games, from one env of two agents


def test_frames_count_env_steps_not_agent_rows(tmp_path):
    """rl_games counts env steps: 2 agents per env do not double max_frames or fps."""
    import os

    from rlchain import Runner
    from tests.conftest import CONFIGS

    cfg = os.path.join(CONFIGS, "ppo_test_cooperative.yaml")
    runner = Runner().load(cfg, [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=1",
                                 "params.config.print_stats=false"])
    result = runner.train()
    config = runner.params.config
    assert result.frames == config.horizon_length * config.num_actors
