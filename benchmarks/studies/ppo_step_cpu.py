"""CPU seconds of the face's Pendulum PPO update with the written-out minibatch step and without it, alternating.

    OMP_NUM_THREADS=1 python -m rlchain.rllib benchmarks/studies/ppo_step_cpu.py [--rounds 6]

Builds RLlib's tuned Pendulum PPO through ``rlchain.rllib`` (``ppo_update_profile.py``'s ``face_algorithm``), runs
``--iterations`` ``train()`` calls, then runs the agent's last update again ``--rounds`` times on each side in one
process, alternating, timing each with ``time.process_time`` (a loaded machine inflates both sides alike; wall
seconds mean nothing there). "autograd": the step as torch's autograd takes it, with torch's ``zero_grad`` and
``get_total_norm`` (rlchain.algos.ppo.analytic_step off); "written out": the library as it is. Each update trains
the live model further; only the seconds matter. Prints each side's per-update seconds, medians and minimums, and
the per-minibatch-step CPU microseconds.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import statistics
import time

import torch

import rlchain.algos.core.optimizer_step as optimizer_step
import rlchain.algos.ppo.agent as agent_module
import rlchain.algos.ppo.loss as ppo_loss


def _update_profile():
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ppo_update_profile.py")
    spec = importlib.util.spec_from_file_location("ppo_update_profile", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _torch_zero_grad(optimizer: torch.optim.Optimizer) -> None:
    optimizer.zero_grad(set_to_none=True)


def _torch_norm(params: list[torch.nn.Parameter], max_norm: float) -> torch.Tensor:
    if math.isinf(max_norm) and max_norm > 0:
        return torch.nn.utils.get_total_norm([p.grad for p in params if p.grad is not None])
    return torch.nn.utils.clip_grad_norm_(params, max_norm)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--iterations", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=6)
    args = parser.parse_args()
    torch.set_num_threads(1)
    algo, caught = _update_profile().face_algorithm(args.seed)
    steps = {"n": 0}
    for _ in range(args.iterations):
        algo.train()
    written_out = (ppo_loss.analytic_step, optimizer_step.clear_grads, optimizer_step.clip_grad_norm)
    autograd = (lambda *a, **k: None, _torch_zero_grad, _torch_norm)
    step = agent_module.optimizer_step

    def counting(*a, **k):  # the agent's minibatch steps, counted
        steps["n"] += 1
        return step(*a, **k)

    seconds = {"autograd": [], "written out": []}
    agent_module.optimizer_step = counting
    for _ in range(args.rounds):
        for side, parts in (("autograd", autograd), ("written out", written_out)):
            ppo_loss.analytic_step, optimizer_step.clear_grads, optimizer_step.clip_grad_norm = parts
            steps["n"] = 0
            start = time.process_time()
            caught["update"]()
            seconds[side].append(time.process_time() - start)
    agent_module.optimizer_step = step
    ppo_loss.analytic_step, optimizer_step.clear_grads, optimizer_step.clip_grad_norm = written_out
    n = steps["n"]
    for side, values in seconds.items():
        print(f"{side:12s} CPU s per update {[round(v, 3) for v in values]} median {statistics.median(values):.3f} "
              f"min {min(values):.3f} ({1e6 * statistics.median(values) / n:.0f} us a step, {n} steps)")
    ratio = statistics.median(seconds["written out"]) / statistics.median(seconds["autograd"])
    least = min(seconds["written out"]) / min(seconds["autograd"])
    print(f"written out / autograd: median {ratio:.3f}, min {least:.3f}; load average {os.getloadavg()[0]:.1f}")
    algo.stop()


if __name__ == "__main__":
    main()
