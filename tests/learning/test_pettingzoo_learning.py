"""Learning tier (slow): the shipped PettingZoo configs (MPE, mpe2 package) learn.

simple_spread (one shared policy) against uniformly random actions; simple_tag (predator and prey
policies) each against its own starting self, both playing the other side's starting self.
"""

import os

import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.inference.policy_player import play_policies
from rlchain.models.build import build_env, build_model
from rlchain.runs.checkpoint import seed_everything
from tests.conftest import CONFIGS, ROOT

pytestmark = pytest.mark.slow
pytest.importorskip("mpe2")


def random_play(params, games, seed=0):
    """Mean agent-episode reward of uniformly random actions over ``games`` env episodes."""
    env = build_env(params, 8, seed)
    rng = np.random.default_rng(seed)
    returns, finished, played = {a: np.zeros(8) for a in env.agent_ids}, [], 0
    env.reset(seed=seed)
    while played < games:
        result = env.step({a: rng.integers(0, env.action_spaces[a].n, 8) for a in env.agent_ids})
        for a in env.agent_ids:
            returns[a] += result.reward[a]
            done = result.terminated[a] | result.truncated[a]
            finished += returns[a][done].tolist()
            returns[a][done] = 0
        played += env.pop_games()
    env.close()
    return float(np.mean(finished))


def starting_models(params, seed):
    """The models a run with ``seed`` starts from (the Runner seeds, builds the env, then the model)."""
    seed_everything(seed)
    env = build_env(params, params.config.num_actors, seed, runners=True, groups=params.config.env_groups)
    models = build_model(params, env, torch.device("cpu"))
    env.close()
    return models


@pytest.mark.timeout(300)
def test_simple_spread_shared_policy_beats_random_play(tmp_path):
    runner = Runner().load(os.path.join(CONFIGS, "ppo_pz_simple_spread.yaml"),
                           [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false"])
    result = runner.train()
    played = runner.play(os.path.join(result.run_dir, "nn", "last_pz_simple_spread.pth"), games=192, quiet=True)
    baseline = random_play(runner.params, 192)
    print(f"simple_spread: trained {played.mean_rewards['shared']:.2f}, random {baseline:.2f}")
    # Random play: about -26 to -27 per agent-episode. The per-game spread (sd ~8; 192 games of 3 agents
    # that share half their reward) gives a standard error of ~0.6 on each mean, ~0.85 on their difference,
    # so 3 points above the random baseline measured here is 3.5 standard errors. Seeds 7, 8, 9 of this
    # config played -22.0, -22.1, -20.2 (96 games each), 4 to 6 points above random
    assert played.mean_rewards["shared"] >= baseline + 3.0, (played.mean_rewards, baseline)


@pytest.mark.timeout(300)
def test_simple_tag_predator_and_prey_each_beat_their_starting_selves(tmp_path):
    runner = Runner().load(os.path.join(CONFIGS, "ppo_pz_simple_tag.yaml"),
                           [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false"])
    params = runner.params
    start = starting_models(params, params.seed)
    result = runner.train()
    trained = Runner().load(os.path.join(CONFIGS, "ppo_pz_simple_tag.yaml"))
    from rlchain.runs import checkpoint as ckpt
    last = os.path.join(result.run_dir, "nn", "last_pz_simple_tag.pth")
    env = build_env(params, 1, 0)
    end = build_model(params, env, torch.device("cpu"))
    env.close()
    ckpt.load_model_state(end, ckpt.load(last), last)

    games = 384

    def rewards(predator, prey):
        """policy -> (mean, standard error) of its agent-episode rewards over ``games`` games; the error
        counts games, not agents (the predators of one game share their reward)."""
        models = torch.nn.ModuleDict({"predator": predator, "prey": prey})
        played = play_policies(trained.params, None, games=games, quiet=True, models=models).rewards
        return {p: (float(np.mean(r)), float(np.std(r) / np.sqrt(games))) for p, r in played.items()}

    before = rewards(start["predator"], start["prey"])
    after = {"predator": rewards(end["predator"], start["prey"])["predator"],
             "prey": rewards(start["predator"], end["prey"])["prey"]}
    margins = {p: (after[p][0] - before[p][0], float(np.hypot(after[p][1], before[p][1]))) for p in after}
    print(f"simple_tag improvement over the starting selves (difference, its standard error): {margins}")
    # start vs start: predators +3 to +4.5 per agent-episode (a catch is +10 to each), the prey -16 to -19
    # (catches and leaving the arena). Each policy must gain at least 3 points and 2.5 standard errors of
    # the difference (~0.5 for the predators, ~1.3 for the prey over 384 games). Seeds 3, 4, 5, 6 of this
    # config gained +7.6, +5.5, +3.9, +4.5 (predator) and +4.2, +8.6, +11.9, +6.3 (prey) over 128 games
    for policy, (gain, se) in margins.items():
        assert gain >= 3.0 and gain >= 2.5 * se, (policy, gain, se)


def test_connect_four_self_play_beats_a_random_player_90_percent(tmp_path):
    """ppo_pz_connect_four_self_play.yaml as shipped (seed 5, 150 epochs, ~40 s): the learner, moving first
    as in training, wins more than 90% of 1000 games against uniformly random legal moves (issue 16's
    bar; seeds 5, 6 and 7 measured 93.1-95.1% with benchmarks/pz_connect_four_vs_random.py, whose
    play_vs_random this test uses)."""
    pytest.importorskip("pettingzoo.classic")
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "pz_connect_four_vs_random", os.path.join(ROOT, "benchmarks", "pz_connect_four_vs_random.py"))
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    runner = Runner().load(os.path.join(CONFIGS, "ppo_pz_connect_four_self_play.yaml"),
                           [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false"])
    runner.train()
    env = build_env(runner.params, 1, 0)
    models = build_model(runner.params, env, torch.device("cpu"))
    env.close()
    # the trained weights are the runner's; load them from its last checkpoint
    from rlchain.runs import checkpoint as ckpt

    path = next(str(p) for p in tmp_path.rglob("last_pz_connect_four.pth"))
    ckpt.load_model_state(models, ckpt.load(path), path)
    score = bench.play_vs_random(runner.params, models, 1000, deterministic=False)
    assert score["win"] / score["games"] > 0.9, score
