"""Play a checkpoint of the Isaac-style cart-pole, the way Isaac Lab's
scripts/reinforcement_learning/rl_games/play.py does.

    python -m rlchain.rl_games examples/isaac_style/play.py [--checkpoint PATH]

Without ``--checkpoint`` it plays the newest run under ``--log_root``: its best checkpoint, else its newest
``last_*`` one.

Steps the env itself with ``agent.get_action(obs, is_deterministic=agent.is_deterministic)`` for
``--steps`` steps and prints the mean return of the episodes that ended.
"""

import argparse
import glob
import math
import os

import torch
import yaml
from cartpole_env import CartpoleDirectEnv, RlGamesGpuEnv, RlGamesVecEnvWrapper
from rl_games.common import env_configurations, vecenv
from rl_games.common.player import BasePlayer
from rl_games.torch_runner import Runner

parser = argparse.ArgumentParser(description="Play a checkpoint of an RL agent from RL-Games.")
parser.add_argument("--num_envs", type=int, default=16, help="Number of environments to simulate.")
parser.add_argument("--checkpoint", type=str, default=None, help="Path to model checkpoint.")
parser.add_argument("--log_root", type=str, default=os.path.join("logs", "rl_games"), help="Where runs are.")
parser.add_argument("--steps", type=int, default=400, help="Env steps to play.")
parser.add_argument("--device", type=str, default=None, help="Device: cpu or cuda:0.")
args_cli = parser.parse_args()

here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "agents", "rl_games_ppo_cfg.yaml")) as fh:
    agent_cfg = yaml.safe_load(fh)
if args_cli.device is not None:
    agent_cfg["params"]["config"]["device"] = args_cli.device
    agent_cfg["params"]["config"]["device_name"] = args_cli.device

name = agent_cfg["params"]["config"]["name"]
if args_cli.checkpoint is None:  # the newest run's checkpoint, as Isaac Lab's get_checkpoint_path finds it
    runs = sorted(glob.glob(os.path.join(args_cli.log_root, name, "*", "nn")), key=os.path.getmtime)
    # the best checkpoint, else the newest last_<name>_ep_<N>_rew_<R>.pth (rl_games' names)
    found = [p for run in runs[-1:] for p in (os.path.join(run, f"{name}.pth"),
                                              *sorted(glob.glob(os.path.join(run, f"last_{name}*.pth")),
                                                      key=os.path.getmtime, reverse=True))
             if os.path.isfile(p)]
    if not found:
        raise SystemExit(f"play.py: no checkpoint under {os.path.join(args_cli.log_root, name)}; pass --checkpoint")
    args_cli.checkpoint = found[0]
resume_path = os.path.abspath(args_cli.checkpoint)
print(f"[INFO]: Loading model checkpoint from: {resume_path}")

# wrap around environment for rl-games
rl_device = agent_cfg["params"]["config"]["device"]
clip_obs = agent_cfg["params"]["env"].get("clip_observations", math.inf)
clip_actions = agent_cfg["params"]["env"].get("clip_actions", math.inf)
env = CartpoleDirectEnv(num_envs=args_cli.num_envs, device=rl_device, seed=7)
env = RlGamesVecEnvWrapper(env, rl_device, clip_obs, clip_actions)

# register the environment to rl-games registry
vecenv.register(
    "IsaacRlgWrapper", lambda config_name, num_actors, **kwargs: RlGamesGpuEnv(config_name, num_actors, **kwargs)
)
env_configurations.register("rlgpu", {"vecenv_type": "IsaacRlgWrapper", "env_creator": lambda **kwargs: env})

# load previously trained model
agent_cfg["params"]["load_checkpoint"] = True
agent_cfg["params"]["load_path"] = resume_path
agent_cfg["params"]["config"]["num_actors"] = env.unwrapped.num_envs

# create runner from rl-games
runner = Runner()
runner.load(agent_cfg)
# obtain the agent from the runner
agent: BasePlayer = runner.create_player()
agent.restore(resume_path)
agent.reset()

# reset environment
obs = env.reset()
if isinstance(obs, dict):
    obs = obs["obs"]
# required: enables the flag for batched observations
_ = agent.get_batch_size(obs, 1)
# initialize RNN states if used
if agent.is_rnn:
    agent.init_rnn()
returns = torch.zeros(args_cli.num_envs)
finished = []
# simulate environment
for _ in range(args_cli.steps):
    with torch.inference_mode():
        obs = agent.obs_to_torch(obs)
        actions = agent.get_action(obs, is_deterministic=agent.is_deterministic)
        obs, rew, dones, _ = env.step(actions)
        returns += rew.cpu()
        if len(dones) > 0:
            # reset rnn state for terminated episodes
            if agent.is_rnn and agent.states is not None:
                for s in agent.states:
                    s[:, dones, :] = 0.0
            for i in dones.nonzero().flatten().tolist():
                finished.append(float(returns[i]))
                returns[i] = 0.0

env.close()
mean = sum(finished) / len(finished) if finished else float("nan")
print(f"[INFO] played {args_cli.steps} steps, {len(finished)} episodes ended, mean return {mean:.2f}")
