"""What ``env_runners/episode_return_mean`` averages, under real RLlib 2.60 and through rlchain's face.

    /work/peers/rllib/bin/python benchmarks/peers/rllib_return_window.py --iterations 6
    python -m rlchain.rllib benchmarks/peers/rllib_return_window.py --iterations 6

Runs RLlib's tuned CartPole PPO (rllib_cartpole.py's settings, 2 env runners) with an ``RLlibCallback`` whose
``on_episode_end`` writes every finished episode's return and its env runner to a file (RLlib's runners are
other processes), and after each ``train()`` prints the reported mean beside two recomputations from that log:
the mean of the runners' means over the episodes that ended during this ``train()`` (each runner's last
``ceil(100 / runners)``: what RLlib reports) and the mean of the last 100 episodes. The script's imports are
RLlib's own; it runs on either side.
"""

import argparse
import json
import math
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from ray.rllib.callbacks.callbacks import RLlibCallback  # noqa: E402
from rllib_cartpole import tuned_cartpole_config  # noqa: E402  (this folder)

LOG = os.environ.setdefault("RLLIB_RETURN_WINDOW_LOG", os.path.join(tempfile.mkdtemp(), "episodes.jsonl"))


class EpisodeLog(RLlibCallback):
    """Every finished episode's whole return (RLlib hands over the last chunk of an episode that spanned two
    ``sample()`` calls: the runner keeps the earlier chunks) and its runner (RLlib: the process; the face: the
    env index, one env per runner here)."""

    def on_episode_end(self, *, episode, env_runner=None, env_index=0, **kwargs):
        ret = float(episode.get_return())
        if env_runner is not None:
            for chunk in getattr(env_runner, "_ongoing_episodes_for_metrics", {}).get(episode.id_, []):
                ret += float(chunk.get_return())
        runner = os.getpid() if env_runner is not None else int(env_index)
        with open(LOG, "a") as f:
            f.write(json.dumps({"t": time.time(), "runner": runner, "return": ret}) + "\n")


def mean(values):
    return sum(values) / len(values) if values else math.nan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=6)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--num-env-runners", type=int, default=2)
    args = parser.parse_args()
    if os.path.exists(LOG):
        os.remove(LOG)
    algo = tuned_cartpole_config(args.seed, args.num_env_runners).callbacks(EpisodeLog).build_algo()
    lib = "rlchain" if type(algo).__module__.startswith("rlchain") else "rllib"
    keep = math.ceil(100 / max(1, args.num_env_runners))
    before, history = 0.0, []
    for _ in range(args.iterations):
        result = algo.train()
        done = time.time()
        episodes = [json.loads(line) for line in open(LOG)] if os.path.exists(LOG) else []
        this = [e for e in episodes if before < e["t"] <= done]
        before = done
        history += [e["return"] for e in this]
        by_runner = {}
        for e in this:
            by_runner.setdefault(e["runner"], []).append(e["return"])
        runner_means = mean([mean(v[-keep:]) for v in by_runner.values()])
        print(json.dumps({"lib": lib, "env_steps": int(result["num_env_steps_sampled_lifetime"]),
                          "reported": round(float(result["env_runners"].get("episode_return_mean", float("nan"))), 3),
                          "runner_means_this_iteration": round(runner_means, 3),
                          "last_100": round(mean(history[-100:]), 3), "episodes": len(this)}), flush=True)
    algo.stop()


if __name__ == "__main__":
    main()
