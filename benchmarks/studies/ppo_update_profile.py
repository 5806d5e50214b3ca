"""Where one PPO update goes on RLlib's tuned Pendulum through the face, beside a bare torch loop of the same steps.

    OMP_NUM_THREADS=1 python -m rlchain.rllib benchmarks/studies/ppo_update_profile.py [--repeats 3] [--cprofile]

Builds RLlib's tuned Pendulum PPO (``benchmarks/peers/rllib_cartpole.py``'s ``tuned_pendulum_config``) through
``rlchain.rllib``, runs ``--iterations`` ``train()`` calls, then times the agent's update on the last rollout
``--repeats`` times (CPU and wall seconds: 30 epochs x 10 minibatches of 128 on relu [256, 256] actor and critic)
and the same number of minibatch steps as a bare torch loop (forward, the clipped surrogate and value loss,
backward, fused Adam, no statistics): the floor the update's own bookkeeping sits on. ``--cprofile`` prints the
update's top functions by own time. Each repeat trains the live model further; only the seconds matter here.
"""

from __future__ import annotations

import argparse
import copy
import cProfile
import importlib.util
import os
import pstats
import statistics
import time

import torch


def _rllib_examples():
    path = os.path.join(os.path.dirname(__file__), "..", "peers", "rllib_cartpole.py")
    spec = importlib.util.spec_from_file_location("rllib_cartpole", os.path.abspath(path))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def face_algorithm(seed: int):
    """The face's Pendulum algorithm and the rlchain PPO it trains (caught on its first update), with the
    arguments of its agent's last ``update`` call under ``"update"`` (a callable running that update again)."""
    from rlchain.algos.ppo.agent import PPOAgent
    from rlchain.algos.ppo.ppo import PPO

    caught = {}
    original, agent_update = PPO.update, PPOAgent.update

    def update(self):
        caught["ppo"] = self
        return original(self)

    def update_agent(self, *args, **kwargs):
        caught["update"] = lambda: agent_update(self, *args, **kwargs)
        return agent_update(self, *args, **kwargs)

    PPO.update, PPOAgent.update = update, update_agent
    algo = _rllib_examples().tuned_pendulum_config(seed, 2).build_algo()
    return algo, caught


def timed(fn, repeats: int) -> tuple[list[float], list[float]]:
    cpu, wall = [], []
    for _ in range(repeats):
        c, w = time.process_time(), time.perf_counter()
        fn()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    return cpu, wall


def bare_loop(model: torch.nn.Module, storage, steps: int, minibatch: int) -> None:
    """The floor: the same network's minibatch steps with nothing around them."""
    model = copy.deepcopy(model)
    params = [p for p in model.parameters() if p.requires_grad]
    opt = torch.optim.Adam(params, lr=2e-4, fused=True)
    size = storage.horizon * storage.num_envs
    obs = storage.obs.reshape(size, -1)
    actions = storage.actions.reshape(size, -1)
    old_logp = storage.log_probs.reshape(size)
    adv = storage.advantages.reshape(size)
    returns = storage.returns.reshape(size, -1)
    dist = model.dist
    done = 0
    while done < steps:
        order = torch.randperm(size)
        for start in range(0, size, minibatch):
            idx = order[start:start + minibatch]
            params_out, values, _ = model.evaluate(obs[idx], None, None, None, None, actions[idx])
            logp, ent = dist.log_prob_and_entropy(params_out, actions[idx])
            ratio = torch.exp(logp - old_logp[idx])
            a_loss = torch.max(-adv[idx] * ratio, -adv[idx] * ratio.clamp(0.8, 1.2)).mean()
            c_loss = (values - returns[idx]).square().clamp(0, 10.0).sum(-1).mean()
            loss = a_loss + c_loss - 0.0 * ent.mean()
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            done += 1
            if done == steps:
                return


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--iterations", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cprofile", action="store_true")
    parser.add_argument("--torch-profile", action="store_true", help="torch.profiler's ops table of each side")
    args = parser.parse_args()
    algo, caught = face_algorithm(args.seed)
    for _ in range(args.iterations):
        algo.train()
    ppo = caught["ppo"]
    storage, cfg = ppo.storage, ppo.cfg
    steps = cfg.mini_epochs * (storage.horizon * storage.num_envs // cfg.minibatch_size)
    print(f"torch threads {torch.get_num_threads()}; {steps} minibatch steps of {cfg.minibatch_size} per update")
    if args.cprofile:
        prof = cProfile.Profile()
        prof.enable()
        caught["update"]()
        prof.disable()
        pstats.Stats(prof).sort_stats("tottime").print_stats(25)
    if args.torch_profile:
        for name, fn in (("agent.update", caught["update"]),
                         ("bare loop", lambda: bare_loop(ppo.model, storage, steps, cfg.minibatch_size))):
            with torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CPU]) as prof:
                fn()
            print(name)
            print(prof.key_averages().table(sort_by="self_cpu_time_total", row_limit=30))
    cpu, wall = timed(caught["update"], args.repeats)
    bcpu, bwall = timed(lambda: bare_loop(ppo.model, storage, steps, cfg.minibatch_size), args.repeats)
    print(f"agent.update: cpu {statistics.median(cpu):.3f} s, wall {statistics.median(wall):.3f} s "
          f"({1e3 * statistics.median(wall) / steps:.2f} ms a step)")
    print(f"bare loop:    cpu {statistics.median(bcpu):.3f} s, wall {statistics.median(bwall):.3f} s "
          f"({1e3 * statistics.median(bwall) / steps:.2f} ms a step)")
    print(f"load average {os.getloadavg()[0]:.2f}")
    algo.stop()


if __name__ == "__main__":
    main()
