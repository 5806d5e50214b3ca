"""Writes the small rl_games checkpoints in this folder with the real rl_games (not rlchain).

Run it with rl_games installed, once per version, e.g. from a venv with ``torch==2.13.0``,
``rl_games==1.6.5`` and ``gym==0.26.2``:

    python tests/data/rl_games/make_checkpoints.py --tag v165
    PYTHONPATH=<rl_games main checkout> python tests/data/rl_games/make_checkpoints.py --tag v20

Each run trains two epochs of PPO, continuous (``a2c_continuous``) and discrete (``a2c_discrete``) with an
8-unit MLP, and continuous with separate actor and critic MLPs of two 8-unit layers, all with input and value
normalization, on a tiny batched torch env that reports OpenAI gym spaces (as Isaac Lab's wrapper does), and
keeps rl_games' last checkpoint as ``<tag>_<kind>.pth`` and the deterministic actions rl_games' player takes
with it as ``<tag>_<kind>_actions.pt``.
``tests/unit/test_rl_games_checkpoint.py`` reads them with the same config (:data:`CONFIGS`).
"""

from __future__ import annotations

import argparse
import copy
import glob
import os
import shutil
import tempfile

import numpy as np
import torch

OBS, ACTIONS, HORIZON = 3, 2, 16


def config(kind: str) -> dict:
    """The rl_games config of ``kind`` these checkpoints were trained with: continuous, discrete, or
    separate (continuous, separate actor and critic MLPs of two layers)."""
    continuous = kind in ("continuous", "separate")
    space = ({"continuous": {"mu_activation": "None", "sigma_activation": "None", "mu_init": {"name": "default"},
                             "sigma_init": {"name": "const_initializer", "val": 0}, "fixed_sigma": True}}
             if continuous else {"discrete": {}})
    return {"params": {
        "seed": 3,
        "algo": {"name": "a2c_continuous" if continuous else "a2c_discrete"},
        "model": {"name": "continuous_a2c_logstd" if continuous else "discrete_a2c"},
        "network": {"name": "actor_critic", "separate": kind == "separate", "space": space,
                    "mlp": {"units": [8, 8] if kind == "separate" else [8], "activation": "elu",
                            "initializer": {"name": "default"}}},
        "config": {"name": f"tiny_{kind}", "env_name": "tiny_env", "device": "cpu", "device_name": "cpu", "ppo": True,
                   "normalize_input": True, "normalize_value": True, "normalize_advantage": True,
                   "reward_shaper": {"scale_value": 1.0}, "num_actors": 4, "horizon_length": 8,
                   "minibatch_size": 16, "mini_epochs": 1, "learning_rate": 3e-4, "lr_schedule": None,
                   "gamma": 0.99, "tau": 0.95, "e_clip": 0.2, "entropy_coef": 0.0, "critic_coef": 2,
                   "clip_value": True, "bounds_loss_coef": 0.0001, "grad_norm": 1.0, "truncate_grads": True,
                   "kl_threshold": 0.008, "max_epochs": 2, "save_frequency": 1, "save_best_after": 1,
                   "score_to_win": 10000, "seq_length": 4, "print_stats": False,
                   "player": {"games_num": 2, "deterministic": True}},
    }}


KINDS = ("continuous", "discrete", "separate")
CONFIGS = {kind: config(kind) for kind in KINDS}


def make_env_class(continuous: bool):
    import gym  # OpenAI gym 0.26: the spaces Isaac Lab's rl_games wrapper returns
    from rl_games.common.ivecenv import IVecEnv

    class TinyVecEnv(IVecEnv):
        """Move a point towards the origin; episodes end after HORIZON steps."""

        def __init__(self, num_envs: int) -> None:
            self.n = num_envs
            self.pos = torch.zeros(num_envs, OBS)
            self.t = torch.zeros(num_envs, dtype=torch.long)
            self.gen = torch.Generator().manual_seed(0)

            self.observation_space = gym.spaces.Box(-np.inf, np.inf, (OBS,), np.float32)
            self.action_space = (gym.spaces.Box(-1.0, 1.0, (ACTIONS,), np.float32) if continuous
                                 else gym.spaces.Discrete(ACTIONS))

        def get_env_info(self) -> dict:
            return {"observation_space": self.observation_space, "action_space": self.action_space}

        def reset(self):
            self.pos = torch.rand(self.n, OBS, generator=self.gen) * 2 - 1
            self.t.zero_()
            return self.pos.clone()

        def step(self, actions):
            push = actions[:, :1] if continuous else (actions.reshape(-1, 1).float() * 2 - 1)
            self.pos = self.pos - 0.1 * push.clamp(-1, 1)
            self.t += 1
            rewards = -self.pos.norm(dim=1)
            dones = self.t >= HORIZON
            if dones.any():
                self.pos[dones] = torch.rand(int(dones.sum()), OBS, generator=self.gen) * 2 - 1
                self.t[dones] = 0
            return self.pos.clone(), rewards, dones, {"time_outs": dones.clone()}

    return TinyVecEnv


def train(kind: str, tag: str, out_dir: str) -> str:
    from rl_games.common import env_configurations, vecenv
    from rl_games.torch_runner import Runner

    env_class = make_env_class(kind != "discrete")
    vecenv.register("TINY", lambda config_name, num_actors, **kwargs: env_class(num_actors))
    env_configurations.register("tiny_env", {"vecenv_type": "TINY", "env_creator": lambda **kwargs: env_class(4)})
    cfg = copy.deepcopy(CONFIGS[kind])
    with tempfile.TemporaryDirectory() as tmp:
        cfg["params"]["config"]["train_dir"] = tmp
        cfg["params"]["config"]["full_experiment_name"] = "run"
        torch.manual_seed(0)
        runner = Runner()
        runner.load(cfg)
        runner.reset()
        runner.run({"train": True, "play": False})
        last = sorted(glob.glob(os.path.join(tmp, "run", "nn", "last_*.pth")), key=os.path.getmtime)[-1]
        target = os.path.join(out_dir, f"{tag}_{kind}.pth")
        shutil.copyfile(last, target)
        # the deterministic actions rl_games' own player takes with it, for the parity test
        player = runner.create_player()
        player.restore(target)
        obs = torch.linspace(-1.5, 1.5, 5 * OBS).reshape(5, OBS)
        player.has_batch_dimension = True
        with torch.no_grad():
            actions = player.get_action(obs, is_deterministic=True)
        torch.save({"obs": obs, "actions": torch.as_tensor(actions).float()},
                   os.path.join(out_dir, f"{tag}_{kind}_actions.pt"))
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tag", required=True, help="file name prefix: the rl_games version (v165, v20)")
    parser.add_argument("--out", default=os.path.dirname(os.path.abspath(__file__)))
    args = parser.parse_args()
    for kind in KINDS:
        print("wrote", train(kind, args.tag, args.out))


if __name__ == "__main__":
    main()
