"""``algo.local_replay_buffer.get_state()`` on a full replay buffer, two code trees side by side: the seconds of one
call and a digest of the state it returns (the same digest: the same state, episode ids aside).

    python benchmarks/studies/rllib_replay_state.py --before /work/main --after . --rows 100000 --rounds 2

Each side runs in its own process with ``PYTHONPATH`` its tree, alternating; 1 env, 64-float observations,
prioritized replay, episodes of ~50 steps, the ring wrapped. Seconds on a loaded machine are not a speed result.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys


def child(rows: int) -> None:
    import hashlib
    import time

    import gymnasium as gym
    import numpy as np
    import torch

    from rlchain.algos.core.replay import ReplayBuffer
    from rlchain.rllib.replay_buffer import LocalReplayBuffer

    dim = 64
    buffer = ReplayBuffer(rows, (dim,), (), action_dtype=torch.int64, prioritized=True)
    gen = torch.Generator().manual_seed(0)
    buffer.obs.copy_(torch.randn(rows, dim, generator=gen))
    buffer.next_obs.copy_(torch.randn(rows, dim, generator=gen))
    buffer.actions.copy_(torch.randint(0, 2, (rows,), generator=gen))
    buffer.rewards.fill_(1.0)
    buffer.discounts.fill_(0.99)
    buffer.terminated.copy_(torch.rand(rows, generator=gen) < 0.02)
    buffer.size, buffer.pos = rows, rows // 3
    buffer.tree.update(np.arange(rows), np.random.default_rng(0).random(rows))
    view = LocalReplayBuffer(buffer, gym.spaces.Box(-np.inf, np.inf, (dim,), np.float32), gym.spaces.Discrete(2),
                             rows, 0)
    wall, cpu = time.perf_counter(), time.process_time()
    state = view.get_state()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    digest = hashlib.sha256()
    for episode in state["episodes"]:
        for column in ("observations", "actions", "rewards"):
            digest.update(np.ascontiguousarray(episode[column]["data"]).tobytes())
        digest.update(repr((episode["t"], episode["is_terminated"], episode["is_truncated"])).encode())
    digest.update(repr(state["_indices"]).encode() + state["_min_segment"].tobytes())
    print(json.dumps({"wall": wall, "cpu": cpu, "episodes": len(state["episodes"]),
                      "digest": digest.hexdigest()[:16]}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", help="the code tree before (a checkout's root)")
    parser.add_argument("--after", default=".", help="the code tree after")
    parser.add_argument("--rows", type=int, default=100_000)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.rows)
        return
    if not args.before:
        parser.error("--before: the code tree to compare with is required")
    for round_ in range(args.rounds):
        for side, tree in (("before", args.before), ("after", args.after)):
            env = {**os.environ, "PYTHONPATH": os.path.abspath(tree), "OMP_NUM_THREADS": "1"}
            out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", "--rows", str(args.rows)],
                                 env=env, capture_output=True, text=True, check=True, cwd=os.path.abspath(tree))
            r = json.loads(out.stdout.strip().splitlines()[-1])
            print(f"round {round_ + 1} {side:6s}: {args.rows} rows, {r['episodes']} episodes, get_state "
                  f"{r['wall']:.2f} s wall / {r['cpu']:.2f} s CPU, state digest {r['digest']}", flush=True)


if __name__ == "__main__":
    main()
