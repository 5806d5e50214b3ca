"""Train Stable-Baselines3 SAC + HerReplayBuffer on envpool's Fetch tasks, for benchmarking against rlchain.

Run it with the interpreter of the venv that holds stable-baselines3 (see benchmarks/README.md,
"Installing the peers"); it reads the rlchain SAC+HER YAML so both libraries train the same task
with the same budget and, where SB3 has the knob, the same hyperparameters::

    /work/rlg-venv/bin/python benchmarks/peers/sb3_her_driver.py \\
        --file rlchain/configs/sac_her_fetch_reach.yaml --seed 0

The task is envpool's ``FetchReach-v4`` / ``FetchPush-v4`` (the YAML's ``env_config.env_name``), the
same C++ env rlchain steps. Each of the ``num_actors`` envs is one envpool env wrapped as a gymnasium
goal env (:class:`EnvpoolFetchGoalEnv`); env i is seeded ``seed + i``, envpool's rule, which is what
rlchain's envpool backend does. envpool has no ``compute_reward``, so the wrapper implements
gymnasium-robotics' documented Fetch reward, ``-(|achieved - desired| > distance_threshold)``
(``-distance`` for ``reward_type: dense``), with the task's own threshold. It cannot import rlchain.

YAML key -> SB3 (``sb3_kwargs``): ``num_actors`` -> n_envs (DummyVecEnv), ``actor_lr`` -> learning_rate
(SB3 has one rate for actor, critics and entropy coefficient: the three must be equal),
``batch_size``, ``replay_buffer_size`` -> buffer_size, ``gamma``, ``critic_tau`` -> tau,
``num_warmup_frames`` -> learning_starts (uniform random actions before it, as rlchain),
``num_updates_per_step`` -> gradient_steps with train_freq 1 (updates after every vectorized step),
``init_alpha`` / ``learnable_temperature`` -> ent_coef ``auto_<init_alpha>``, ``target_entropy``,
``network.mlp.units`` / ``activation`` -> net_arch / activation_fn (actor and both critics),
``replay.her.k`` / ``strategy`` -> n_sampled_goal / goal_selection_strategy, ``normalize_input`` ->
VecNormalize(norm_obs=True, norm_reward=False) (HerReplayBuffer stores raw observations and
normalizes sampled ones, rewards are recomputed from raw goals), ``max_frames`` -> total_timesteps,
``games_to_track`` -> stats_window_size. Not matched (SB3 has no knob): ``log_std_bounds`` (SB3 clips
the log-std to [-20, 2]), ``policy_frequency`` other than 1.

Every ``num_actors * num_steps_per_episode`` frames (one rlchain epoch) the driver writes the TensorBoard
scalars ``rewards/step`` (mean return of the last ``games_to_track`` episodes) and
``episodes/success_rate`` (the fraction of them whose last step had ``info['is_success']``, SB3's
``ep_success_buffer``; rlchain's ``success_mode: last``), x = env frames, under
``./runs/<name>_<dd-HH-MM-SS>/summaries`` in the working directory (the layout benchmarks/peers/compare.py
reads). This script only calls SB3's public API; it contains no SB3 code.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time

import numpy as np

ACTIVATIONS = {"relu": "ReLU", "elu": "ELU", "tanh": "Tanh", "selu": "SELU", "None": "Identity"}


def fetch_reward(achieved_goal: np.ndarray, desired_goal: np.ndarray, distance_threshold: float,
                 reward_type: str) -> np.ndarray:
    """gymnasium-robotics' documented Fetch reward over the leading axes: with d the Euclidean distance
    of the goals, ``-(d > distance_threshold)`` (sparse: 0 or -1) or ``-d`` (dense). float32."""
    d = np.linalg.norm(np.asarray(achieved_goal, np.float64) - np.asarray(desired_goal, np.float64), axis=-1)
    if reward_type == "dense":
        return (-d).astype(np.float32)
    return -(d > distance_threshold).astype(np.float32)


def make_goal_env_class():
    """The gymnasium goal-env class (built on demand: gymnasium is imported only in the peer venv)."""
    import envpool
    import gymnasium as gym

    class EnvpoolFetchGoalEnv(gym.Env):
        """One envpool Fetch env as a gymnasium goal env: Dict obs (float32), ``info['is_success']``
        and ``compute_reward(achieved_goal, desired_goal, info)``. envpool is seeded at creation only,
        so ``reset(seed=...)`` ignores the seed; envpool's own time limit ends episodes (truncated)."""

        metadata: dict = {"render_modes": []}

        def __init__(self, task_id: str, seed: int, **env_kwargs) -> None:
            self.task_id = task_id
            self.pool = envpool.make(task_id, env_type="gymnasium", num_envs=1, batch_size=1, seed=int(seed),
                                     **env_kwargs)
            config = envpool.make_spec(task_id).config._asdict()
            config.update(env_kwargs)
            self.distance_threshold = float(config["distance_threshold"])
            self.reward_type = str(config["reward_type"])
            self.observation_space = gym.spaces.Dict({
                key: gym.spaces.Box(-np.inf, np.inf, space.shape, np.float32)
                for key, space in self.pool.observation_space.spaces.items()})
            self.action_space = self.pool.action_space

        def _obs(self, obs: dict) -> dict:
            return {key: np.asarray(value[0], np.float32) for key, value in obs.items()}

        def reset(self, *, seed: int | None = None, options: dict | None = None):
            obs, info = self.pool.reset()
            return self._obs(obs), {"is_success": float(info["is_success"][0])}

        def step(self, action):
            obs, reward, terminated, truncated, info = self.pool.step(np.asarray(action, np.float32)[None])
            return (self._obs(obs), float(reward[0]), bool(terminated[0]), bool(truncated[0]),
                    {"is_success": float(info["is_success"][0])})

        def compute_reward(self, achieved_goal, desired_goal, info):
            return fetch_reward(achieved_goal, desired_goal, self.distance_threshold, self.reward_type)

        def close(self) -> None:
            self.pool.close()

    return EnvpoolFetchGoalEnv


def load_rlchain_yaml(path: str) -> dict:
    """The ``params`` block of an rlchain SAC+HER YAML."""
    import yaml

    with open(path) as f:
        params = yaml.safe_load(f)["params"]
    config = params["config"]
    if params["algo"]["name"] != "sac" or not (config.get("replay") or {}).get("her"):
        sys.exit(f"{path}: expected algo sac with replay.her (an rlchain SAC+HER config)")
    return params


def sb3_kwargs(params: dict) -> dict:
    """SB3 SAC keyword arguments (and the HER / VecNormalize / budget settings) from the YAML's params;
    exits naming the key where SB3 cannot match it."""
    c, net = params["config"], params["network"]
    lrs = {key: float(c.get(key, 3e-4)) for key in ("actor_lr", "critic_lr", "alpha_lr")}
    if len(set(lrs.values())) != 1:
        sys.exit(f"SB3 SAC has one learning rate; the YAML has {lrs}")
    if int(c.get("policy_frequency", 1)) != 1:
        sys.exit("SB3 SAC updates the actor at every gradient step; the YAML has policy_frequency != 1")
    import torch

    act = str(net["mlp"].get("activation", "relu"))
    alpha = float(c.get("init_alpha", 1.0))
    her = c["replay"]["her"]
    return {
        "n_envs": int(c.get("num_actors", 1)),
        "learning_rate": lrs["actor_lr"],
        "batch_size": int(c.get("batch_size", 256)),
        "buffer_size": int(c.get("replay_buffer_size", 100_000)),
        "gamma": float(c.get("gamma", 0.99)),
        "tau": float(c.get("critic_tau", 0.005)),
        "learning_starts": int(c.get("num_warmup_frames") or 0),
        "train_freq": 1,
        "gradient_steps": int(c.get("num_updates_per_step", 1)),
        "ent_coef": f"auto_{alpha}" if c.get("learnable_temperature", True) else alpha,
        "target_entropy": float(c["target_entropy"]) if c.get("target_entropy") is not None else "auto",
        "net_arch": [int(u) for u in net["mlp"]["units"]],
        "activation_fn": getattr(torch.nn, ACTIVATIONS[act]),
        "n_sampled_goal": int(her.get("k", 4)),
        "goal_selection_strategy": str(her.get("strategy", "future")),
        "normalize_input": bool(c.get("normalize_input", False)),
        "total_timesteps": int(c["max_frames"]),
        "window": int(c.get("games_to_track", 100)),
        "log_every": int(c.get("num_actors", 1)) * int(c.get("num_steps_per_episode", 1)),
        "task": c["env_config"]["env_name"],
        "env_kwargs": {k: v for k, v in c["env_config"].items() if k not in ("env_name", "seed")},
    }


def parse_args(argv=None):
    """Parse the command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--file", required=True, help="the rlchain SAC+HER YAML to match")
    p.add_argument("--seed", type=int, default=None, help="default: the YAML's params.seed")
    p.add_argument("--max-frames", type=int, default=None, help="default: the YAML's max_frames")
    p.add_argument("--name", default=None, help="run name (default: sb3_<the YAML's config.name>)")
    p.add_argument("--torch-threads", type=int, default=None,
                   help="torch.set_num_threads (default: torch's own)")
    return p.parse_args(argv)


def _exit_on_sigterm(signum, frame):
    """Turn SIGTERM into SystemExit so the writer is closed (flushed)."""
    sys.exit(128 + signum)


def main(argv=None):
    """Build SB3 SAC + HER on the YAML's Fetch task and train it, logging success and reward."""
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    args = parse_args(argv)
    params = load_rlchain_yaml(args.file)
    hp = sb3_kwargs(params)
    seed = params.get("seed", 0) if args.seed is None else args.seed
    total = args.max_frames or hp["total_timesteps"]
    import torch
    from stable_baselines3 import SAC, HerReplayBuffer
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize
    from torch.utils.tensorboard import SummaryWriter

    if args.torch_threads:
        torch.set_num_threads(args.torch_threads)
    name = args.name or f"sb3_{params['config'].get('name', 'her')}"
    run_dir = os.path.join("runs", f"{name}_{time.strftime('%d-%H-%M-%S')}")
    writer = SummaryWriter(os.path.join(run_dir, "summaries"), flush_secs=1)
    goal_env = make_goal_env_class()

    class SuccessLogger(BaseCallback):
        """rewards/step and episodes/success_rate every log_every frames (one rlchain epoch)."""

        next_log = hp["log_every"]

        def _on_step(self):
            if self.num_timesteps < self.next_log:
                return True
            self.next_log += hp["log_every"]
            returns, successes = self.model.ep_info_buffer, self.model.ep_success_buffer
            if returns:
                writer.add_scalar("rewards/step", float(np.mean([ep["r"] for ep in returns])), self.num_timesteps)
            if successes:
                rate = float(np.mean(successes))
                writer.add_scalar("episodes/success_rate", rate, self.num_timesteps)
                print(f"frames {self.num_timesteps} success_rate {rate:.2f} episodes {len(successes)}", flush=True)
            return True

    try:
        env = DummyVecEnv([
            (lambda i=i: Monitor(goal_env(hp["task"], seed + i, **hp["env_kwargs"])))
            for i in range(hp["n_envs"])])
        if hp["normalize_input"]:
            env = VecNormalize(env, norm_obs=True, norm_reward=False, gamma=hp["gamma"])
        model = SAC("MultiInputPolicy", env, learning_rate=hp["learning_rate"], buffer_size=hp["buffer_size"],
                    learning_starts=hp["learning_starts"], batch_size=hp["batch_size"], tau=hp["tau"],
                    gamma=hp["gamma"], train_freq=hp["train_freq"], gradient_steps=hp["gradient_steps"],
                    ent_coef=hp["ent_coef"], target_entropy=hp["target_entropy"],
                    replay_buffer_class=HerReplayBuffer,
                    replay_buffer_kwargs=dict(n_sampled_goal=hp["n_sampled_goal"],
                                              goal_selection_strategy=hp["goal_selection_strategy"]),
                    policy_kwargs=dict(net_arch=hp["net_arch"], activation_fn=hp["activation_fn"]),
                    stats_window_size=hp["window"], seed=seed, device="cpu", verbose=0)
        print(f"SB3 SAC+HER on {hp['task']}: {hp['n_envs']} envs, {total} frames, seed {seed}, "
              f"torch threads {torch.get_num_threads()}", flush=True)
        model.learn(total_timesteps=total, callback=SuccessLogger())
    finally:
        writer.close()


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:  # the benchmark stops runs with SIGINT first
        sys.exit(130)
