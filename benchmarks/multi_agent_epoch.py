"""CPU time of one PPO epoch on rl_games' kind of multi-agent env (agents flattened into the batch).

    python benchmarks/multi_agent_epoch.py --epochs 30          # rlchain/configs/ppo_test_cooperative.yaml

Runs the single-policy trainer's rollout and update (``OnPolicyTrainer.rollout`` + ``learn``) for
``--epochs`` epochs after 3 warm-up epochs, with one torch thread, and prints the process CPU seconds
per epoch (``time.process_time``: less sensitive than wall time to other processes on a busy
machine) and the wall seconds. Run it from two checkouts in turns to compare them.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import torch

ROOT = os.getcwd()
sys.path.insert(0, ROOT)

from rlchain import Runner  # noqa: E402
from rlchain.algos.ppo.trainer import OnPolicyTrainer  # noqa: E402
from rlchain.models.build import build_env, build_model  # noqa: E402
from rlchain.runs.logging import TrainLogger  # noqa: E402
from rlchain.training.loop import Loop  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", default=os.path.join(ROOT, "rlchain", "configs", "ppo_test_cooperative.yaml"))
    parser.add_argument("--epochs", type=int, default=30)
    args = parser.parse_args()
    torch.set_num_threads(1)
    runner = Runner().load(args.config, ["params.config.print_stats=false"])
    params = runner.params
    env = build_env(params, params.config.num_actors, 0)
    model = build_model(params, env, torch.device("cpu"))
    loop = Loop(params, OnPolicyTrainer, env, model, torch.device("cpu"), None, TrainLogger(None, False), 0, runner.raw)
    trainer = loop.algorithm
    trainer.start()
    for _ in range(3):
        trainer.rollout()
        trainer.learn()
    cpu, wall = time.process_time(), time.time()
    for _ in range(args.epochs):
        trainer.rollout()
        trainer.learn()
    cpu, wall = (time.process_time() - cpu) / args.epochs, (time.time() - wall) / args.epochs
    batch = trainer.frames_per_epoch() * loop.num_agents
    print(f"{os.path.basename(ROOT)}: {cpu * 1000:.1f} ms CPU / epoch, {wall * 1000:.1f} ms wall / epoch "
          f"({batch} agent steps per epoch), load {os.getloadavg()[0]:.1f}")
    env.close()


if __name__ == "__main__":
    main()
