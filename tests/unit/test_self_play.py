"""Self-play: the callback's update rule, the frozen opponent, the config block and the duel env."""

import copy
import os
import types

import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.algos.base.episodes import EpisodeTracker
from rlchain.config.errors import ConfigError
from rlchain.config.load import parse_params
from rlchain.config.ppo import SelfPlayConfig
from rlchain.envs.examples.duel import DuelVecEnv, RandomPolicy, SafePolicy, distances, play_duel
from rlchain.models.build import build_model
from rlchain.training.self_play import FrozenPolicy, SelfPlayCallback
from tests.conftest import BASE, CONFIGS


def duel_raw(**self_play):
    raw = copy.deepcopy(BASE)
    raw["params"]["config"].update(env_name="duel", self_play_config=self_play or None)
    return raw


class Logger:
    def __init__(self):
        self.scalars = []

    def scalar(self, tag, value, step):
        self.scalars.append((tag, value))


class ScoringEnv:
    """Records opponent updates; hands out the scores a test queues."""

    def __init__(self, num_envs=4):
        self.num_envs = num_envs
        self.updates = []
        self.queued = []

    def set_opponent(self, policy, env_ids=None):
        self.updates.append((policy, None if env_ids is None else list(env_ids)))

    def pop_scores(self):
        out, self.queued = np.asarray(self.queued, dtype=float), []
        return out


def fake_trainer(env, epoch=0):
    model = build_model(parse_params(duel_raw(), "<test>"), DuelVecEnv(1), torch.device("cpu"))
    logger = Logger()  # a CallbackContext's face: what self-play reads and writes of the run
    return types.SimpleNamespace(model=model, state=types.SimpleNamespace(epoch=epoch, frames=0), logger=logger,
                                 scalar=lambda tag, value: logger.scalar(tag, value, 0), emit=lambda event: None,
                                 episode_tracker=EpisodeTracker(env.num_envs, 100, torch.device("cpu")),
                                 params=types.SimpleNamespace(config=types.SimpleNamespace(print_stats=False)))


def callback(env, **changes):
    cfg = SelfPlayConfig(**{"update_score": 0.5, "games_to_check": 4, "check_scores": True, **changes})
    return SelfPlayCallback(cfg, env)


def epoch(cb, trainer, env, scores):
    env.queued = list(scores)
    cb.on_epoch_end(trainer, {}, None)


def test_updates_only_after_enough_games_above_the_score():
    env = ScoringEnv()
    trainer = fake_trainer(env)
    cb = callback(env)
    cb.on_train_start(trainer)
    epoch(cb, trainer, env, [1, 1, 1])  # 3 < games_to_check
    assert env.updates == []
    epoch(cb, trainer, env, [0, 0])  # the last 4 games: 1, 1, 0, 0 -> 0.5 is not above 0.5
    assert env.updates == []
    epoch(cb, trainer, env, [1])  # 1, 0, 0, 1 -> 0.5 again
    assert env.updates == []
    epoch(cb, trainer, env, [1, 1])  # 0, 1, 1, 1 -> 0.75
    assert len(env.updates) == 1 and env.updates[0][1] == [0]
    assert isinstance(env.updates[0][0], FrozenPolicy)
    assert ("selfplay/iters_update_weigths", 4) in trainer.logger.scalars
    epoch(cb, trainer, env, [1, 1, 1])  # the count starts again after an update
    assert len(env.updates) == 1
    epoch(cb, trainer, env, [1])
    assert len(env.updates) == 2 and cb.updates == 2


def test_window_of_envs_moves_by_one_per_update():
    env = ScoringEnv(num_envs=3)
    trainer = fake_trainer(env)
    cb = callback(env, env_update_num=2, games_to_check=1)
    for _ in range(4):
        epoch(cb, trainer, env, [1])
    assert [ids for _, ids in env.updates] == [[0, 1], [1, 2], [2, 0], [0, 1]]
    everyone = callback(env, env_update_num=10, games_to_check=1)
    epoch(everyone, trainer, env, [1])
    assert env.updates[-1][1] == [0, 1, 2]


def test_episode_rewards_are_the_score_without_check_scores():
    env = ScoringEnv(num_envs=2)
    trainer = fake_trainer(env)
    cb = callback(env, check_scores=False, update_score=0.0, games_to_check=3)
    trainer.episode_tracker.step(torch.tensor([-1.0, 1.0]), torch.tensor([True, True]))
    cb.on_train_start(trainer)  # games before the start are not counted
    trainer.episode_tracker.step(torch.tensor([1.0, -1.0]), torch.tensor([True, True]))
    cb.on_epoch_end(trainer, {}, None)
    assert list(cb.scores) == [1.0, -1.0] and env.updates == []
    trainer.episode_tracker.step(torch.tensor([0.0, 1.0]), torch.tensor([False, True]))
    cb.on_epoch_end(trainer, {}, None)  # 1, -1, 1 -> 1/3 > 0
    assert len(env.updates) == 1


def test_the_opponent_is_a_frozen_copy():
    env = ScoringEnv()
    trainer = fake_trainer(env)
    cb = callback(env, games_to_check=1, deterministic=True)
    epoch(cb, trainer, env, [1])
    opponent = env.updates[0][0]
    assert opponent.model is not trainer.model and not opponent.model.training
    assert all(not p.requires_grad for p in opponent.model.parameters())
    obs = DuelVecEnv(8, seed=0).reset()
    before = opponent(obs)
    assert before.shape == (8,) and set(before.tolist()) <= {0, 1, 2}
    with torch.no_grad():
        for p in trainer.model.parameters():
            p.add_(torch.randn_like(p))
    np.testing.assert_array_equal(opponent(obs), before)  # deterministic and unaffected by training


def test_resume_loads_the_resumed_policy_everywhere():
    env = ScoringEnv()
    cb = callback(env)
    cb.on_train_start(fake_trainer(env, epoch=0))
    assert env.updates == []
    cb.on_train_start(fake_trainer(env, epoch=7))
    assert env.updates[0][1] is None


def test_env_must_support_self_play():
    class Plain:
        num_envs = 2

    with pytest.raises(ConfigError, match="params.config.self_play_config: needs an env with set_opponent"):
        callback(Plain())

    class NoScores(Plain):
        def set_opponent(self, policy, env_ids=None):
            pass

    with pytest.raises(ConfigError, match="self_play_config.check_scores: True needs an env with pop_scores"):
        callback(NoScores())
    callback(NoScores(), check_scores=False)


def test_config_block():
    cfg = parse_params(duel_raw(update_score=0.1, games_to_check=100, env_update_num=8), "<t>").config
    assert cfg.self_play_config == SelfPlayConfig(update_score=0.1, games_to_check=100, env_update_num=8)
    assert not cfg.self_play_config.check_scores and not cfg.self_play_config.deterministic
    assert parse_params(duel_raw(), "<t>").config.self_play_config is None
    with pytest.raises(ConfigError, match="self_play_config.games_to_check: required key is missing"):
        parse_params(duel_raw(update_score=1), "<t>")
    with pytest.raises(ConfigError, match="self_play_config.check_score: unknown key; did you mean 'check_scores'"):
        parse_params(duel_raw(update_score=1, games_to_check=10, check_score=True), "<t>")


# ----- the duel env -------------------------------------------------------------------------
def test_duel_rules_rewards_and_scores():
    env = DuelVecEnv(2, seed=0, min_distance=8, max_distance=8)
    env.set_opponent(lambda obs: np.full(len(obs), 2))  # always moves 3
    obs = env.reset()
    started = distances(obs)  # 8, or 5 where the opponent moved first
    assert set(started.tolist()) <= {8, 5} and obs.shape == (2, 9) and obs.sum(1).tolist() == [1, 1]
    env.distance[:] = [3, 6]
    result = env.step(np.array([2, 0]))  # env 0: moves 3 and wins; env 1: 6 -> 5 -> opponent 3 -> 2
    assert result.reward.tolist() == [1.0, 0.0] and result.terminated.tolist() == [True, False]
    assert distances(result.final_obs)[0] == 0 and distances(result.obs)[1] == 2
    result = env.step(np.array([0, 0]))  # env 1: 2 -> 1 -> the opponent reaches the goal
    assert result.reward[1] == -1.0 and result.terminated[1]
    assert env.pop_scores().tolist() == [1.0, 0.0] and env.pop_scores().size == 0
    assert not result.truncated.any()


def test_duel_opponent_slots():
    env = DuelVecEnv(3, seed=0)
    calls = []
    policy = lambda obs: calls.append(len(obs)) or np.zeros(len(obs), dtype=np.int64)  # noqa: E731
    env.set_opponent(policy, [1])
    assert env.opponents[1] is policy and env.opponents[0] is env.opponents[2] is not policy
    env.reset()
    for _ in range(5):
        env.step(np.zeros(3, dtype=np.int64))
    assert calls and max(calls) == 1  # only env 1's rows reach it, in one call per step


def test_heuristic_and_perfect_play():
    heuristic = SafePolicy(3, seed=0)
    d = np.array([2, 5, 6, 7, 9])
    obs = np.eye(21, dtype=np.float32)[d]
    moves = heuristic(obs) + 1
    assert moves[0] == 2 and moves[1] == 1  # wins when in reach; from 5 only 1 keeps the goal away
    assert (d[2:4] - moves[2:4] > 3).all()  # never leaves the goal in reach when it can avoid it

    def perfect(obs):
        r = distances(obs) % 4
        return np.where(r == 0, 0, r - 1)

    assert 0.75 < play_duel(heuristic, "random", 2000, seed=1) < 0.9  # exact value 0.82
    assert play_duel(perfect, "heuristic", 2000, seed=2) > 0.93  # exact value 0.96
    assert play_duel(RandomPolicy(3, 5), "heuristic", 2000, seed=3) < 0.25  # exact value 0.18


def keep_self_play(monkeypatch) -> list[SelfPlayCallback]:
    """The self-play callbacks the loops built from now on (the loop adds its own; callbacks do not see it)."""
    import rlchain.training.loop as loop_module

    kept = []

    class Kept(SelfPlayCallback):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            kept.append(self)

    monkeypatch.setattr(loop_module, "SelfPlayCallback", Kept)
    return kept


@pytest.mark.smoke
def test_duel_config_trains_with_updates_and_plays(tmp_path, monkeypatch):
    kept = keep_self_play(monkeypatch)
    runner = Runner().load(os.path.join(CONFIGS, "ppo_duel_self_play.yaml"), [
        f"params.config.train_dir={tmp_path}", "params.config.max_epochs=3", "params.config.print_stats=false",
        "params.config.self_play_config.games_to_check=20", "params.config.self_play_config.update_score=-1"])
    result = runner.train()
    assert result.epoch == 3 and [k.updates for k in kept] == [3]  # 512 steps make > 20 games every epoch
    played = runner.play(os.path.join(result.run_dir, "nn", "last_duel_self_play.pth"), games=20, quiet=True)
    assert played.games == 20 and set(played.rewards) <= {-1.0, 1.0}  # against the env's random opponent
