"""Connect four self-play (rlchain/configs/ppo_pz_connect_four_self_play.yaml) against a random player.

    python benchmarks/studies/pz_connect_four_vs_random.py                       # train the shipped config, then play
    python benchmarks/studies/pz_connect_four_vs_random.py --checkpoint runs/x/nn/last_pz_connect_four.pth
    python benchmarks/studies/pz_connect_four_vs_random.py --games 1000 --deterministic

The trained ``learner`` policy plays player_0 (it moves first, as in training) against a player that
picks uniformly among the legal moves (the env's action mask). Prints wins / draws / losses and the
win rate; ``--min-win-rate`` makes the exit status 1 below it.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if __package__ in (None, ""):  # run by path: this checkout's rlchain and benchmarks first
    sys.path.insert(0, ROOT)

from rlchain import Runner  # noqa: E402
from rlchain.models.build import build_env, build_model  # noqa: E402
from rlchain.runs import checkpoint as ckpt  # noqa: E402

CONFIG = os.path.join(ROOT, "rlchain", "configs", "ppo_pz_connect_four_self_play.yaml")


def play_vs_random(params, models, games: int, deterministic: bool, seed: int = 0, num_envs: int = 16) -> dict:
    """``learner`` as player_0 against uniformly random legal moves: {'win', 'draw', 'loss', 'games'}."""
    env = build_env(params, num_envs, seed)
    rng = np.random.default_rng(seed)
    learner = models["learner"].eval()
    score = {"win": 0, "draw": 0, "loss": 0}
    views = env.reset(seed=seed)
    returns = np.zeros(num_envs)
    while sum(score.values()) < games:
        me = views["player_0"]
        with torch.inference_mode():
            out = learner.act(torch.as_tensor(me.obs), deterministic=deterministic,
                              action_masks=torch.as_tensor(me.mask))
        other = views["player_1"].mask
        random_moves = np.array([rng.choice(np.flatnonzero(m)) for m in other])
        result = env.step({"player_0": learner.dist.to_env(out["actions"]).numpy(), "player_1": random_moves})
        returns += result.reward["player_0"]
        for i in np.flatnonzero(result.terminated["player_0"] | result.truncated["player_0"]):
            score["win" if returns[i] > 0 else "loss" if returns[i] < 0 else "draw"] += 1
            returns[i] = 0
        views = result.obs
    env.close()
    score["games"] = sum(score.values())
    return score


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--checkpoint", help="a checkpoint of the config (default: train it first)")
    parser.add_argument("--games", type=int, default=500)
    parser.add_argument("--deterministic", action="store_true", help="the learner plays its mode, not samples")
    parser.add_argument("--train-dir", default="runs")
    parser.add_argument("--min-win-rate", type=float, default=None)
    args = parser.parse_args()
    runner = Runner().load(CONFIG, [f"params.config.train_dir={args.train_dir}", "params.config.print_stats=false"])
    path = args.checkpoint
    if path is None:
        start = time.time()
        result = runner.train()
        path = os.path.join(result.run_dir, "nn", "last_pz_connect_four.pth")
        print(f"trained {result.epoch} epochs, {result.frames} moves in {time.time() - start:.0f} s -> {path}")
    env = build_env(runner.params, 1, 0)
    models = build_model(runner.params, env, torch.device("cpu"))
    env.close()
    ckpt.load_model_state(models, ckpt.load(path), path)
    score = play_vs_random(runner.params, models, args.games, args.deterministic)
    rate = score["win"] / score["games"]
    print(f"learner (player_0) vs random legal moves: {score['win']} wins, {score['draw']} draws, "
          f"{score['loss']} losses in {score['games']} games: win rate {rate:.3f}")
    return 1 if args.min_win_rate is not None and rate < args.min_win_rate else 0


if __name__ == "__main__":
    sys.exit(main())
