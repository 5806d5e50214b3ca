"""Train Stable-Baselines3 PPO on CartPole-v1, for benchmarking.

Run it with the interpreter of the venv that holds stable-baselines3 (see
benchmarks/README.md, "Installing the peers")::

    /work/rlg-venv/bin/python benchmarks/peers/sb3_driver.py --threshold 400 --seed 0

Hyperparameters are rl-baselines3-zoo's tuned ones for CartPole-v1
(``hyperparams/ppo.yml``): 8 envs (``make_vec_env``, DummyVecEnv), MlpPolicy,
n_steps 32, batch_size 256, gae_lambda 0.8, gamma 0.98, n_epochs 20,
ent_coef 0.0, learning_rate lin_0.001, clip_range lin_0.2, n_timesteps 1e5.

After every rollout the driver writes the TensorBoard scalar ``rewards/step``
(x = total env frames, y = mean return of the last 100 finished episodes,
SB3's ``ep_info_buffer``) under ``./runs/<name>_<dd-HH-MM-SS>/summaries`` in
the current working directory, the layout ``benchmarks/peers/compare.py`` reads.
Training stops once that mean is >= ``--threshold`` or at n_timesteps.  This
script only calls SB3's public API; it contains no SB3 code.
"""

import argparse
import os
import signal
import sys
import time

ZOO_CARTPOLE = dict(  # rl-baselines3-zoo hyperparams/ppo.yml, CartPole-v1
    n_envs=8, n_timesteps=100_000, policy="MlpPolicy", n_steps=32,
    batch_size=256, gae_lambda=0.8, gamma=0.98, n_epochs=20, ent_coef=0.0,
    learning_rate=0.001, clip_range=0.2)  # the last two: lin_ (to 0)


def parse_args(argv=None):
    """Parse the command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--threshold", type=float, default=400.0,
                   help="stop once the 100-episode mean return is >= this")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--n-timesteps", type=int,
                   default=ZOO_CARTPOLE["n_timesteps"],
                   help="training budget (also the schedules' horizon)")
    p.add_argument("--name", default="sb3_ppo_cartpole",
                   help="run name: ./runs/<name>_<dd-HH-MM-SS>/summaries")
    p.add_argument("--torch-threads", type=int, default=None,
                   help="torch.set_num_threads (default: torch's own)")
    return p.parse_args(argv)


def _exit_on_sigterm(signum, frame):
    """Turn SIGTERM into SystemExit so the writer is closed (flushed)."""
    sys.exit(128 + signum)


def main(argv=None):
    """Build the zoo's CartPole PPO and train it, logging rewards/step."""
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    args = parse_args(argv)
    import numpy as np
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.utils import LinearSchedule
    from stable_baselines3.common.vec_env import DummyVecEnv
    from torch.utils.tensorboard import SummaryWriter

    if args.torch_threads:
        torch.set_num_threads(args.torch_threads)
    hp = ZOO_CARTPOLE
    run_dir = os.path.join("runs", f"{args.name}_{time.strftime('%d-%H-%M-%S')}")
    writer = SummaryWriter(os.path.join(run_dir, "summaries"), flush_secs=1)

    class RewardLogger(BaseCallback):
        """Write rewards/step after each rollout; stop at the threshold."""

        reached = False

        def _on_step(self):
            return not self.reached  # False ends model.learn()

        def _on_rollout_end(self):
            buf = self.model.ep_info_buffer
            if not buf:
                return
            mean = float(np.mean([ep["r"] for ep in buf]))
            writer.add_scalar("rewards/step", mean, self.num_timesteps)
            writer.flush()
            print(f"frames {self.num_timesteps} mean_return {mean:.1f} "
                  f"episodes {len(buf)}", flush=True)
            self.reached = mean >= args.threshold

    try:
        env = make_vec_env("CartPole-v1", n_envs=hp["n_envs"], seed=args.seed,
                           vec_env_cls=DummyVecEnv)
        model = PPO(hp["policy"], env, n_steps=hp["n_steps"],
                    batch_size=hp["batch_size"], gae_lambda=hp["gae_lambda"],
                    gamma=hp["gamma"], n_epochs=hp["n_epochs"],
                    ent_coef=hp["ent_coef"],
                    learning_rate=LinearSchedule(hp["learning_rate"], 0.0, 1.0),
                    clip_range=LinearSchedule(hp["clip_range"], 0.0, 1.0),
                    seed=args.seed, device="cpu", verbose=0)
        model.learn(total_timesteps=args.n_timesteps, callback=RewardLogger())
    finally:
        writer.close()


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:  # compare.py stops runs with SIGINT first
        sys.exit(130)
