"""Train the Isaac-style cart-pole with rl_games, the way Isaac Lab's
scripts/reinforcement_learning/rl_games/train.py does.

    python -m rlchain.rl_games examples/isaac_style/train.py --num_envs 512 --max_iterations 100

(``python examples/isaac_style/train.py ...`` runs the same script on rl_games itself.) The env stands in
for Isaac Lab's: cartpole_env.py. Resume with
``--checkpoint logs/rl_games/cartpole_direct/<run>/nn/last_cartpole_direct_ep_<N>_rew_<R>.pth``.
"""

import argparse
import math
import os
from datetime import datetime

import yaml
from cartpole_env import CartpoleDirectEnv, RlGamesGpuEnv, RlGamesVecEnvWrapper
from rl_games.common import env_configurations, vecenv
from rl_games.common.algo_observer import IsaacAlgoObserver
from rl_games.torch_runner import Runner

parser = argparse.ArgumentParser(description="Train an RL agent with RL-Games.")
parser.add_argument("--num_envs", type=int, default=None, help="Number of environments to simulate.")
parser.add_argument("--seed", type=int, default=None, help="Seed used for the environment")
parser.add_argument("--device", type=str, default=None, help="Device: cpu or cuda:0.")
parser.add_argument("--checkpoint", type=str, default=None, help="Path to model checkpoint.")
parser.add_argument("--sigma", type=str, default=None, help="The policy's initial standard deviation.")
parser.add_argument("--max_iterations", type=int, default=None, help="RL Policy training iterations.")
parser.add_argument("--log_root", type=str, default=os.path.join("logs", "rl_games"), help="Where runs go.")
args_cli, overrides = parser.parse_known_args()

here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "agents", "rl_games_ppo_cfg.yaml")) as fh:
    agent_cfg = yaml.safe_load(fh)

# override configurations with non-hydra CLI arguments
if args_cli.seed is not None:
    agent_cfg["params"]["seed"] = args_cli.seed
if args_cli.device is not None:
    agent_cfg["params"]["config"]["device"] = args_cli.device
    agent_cfg["params"]["config"]["device_name"] = args_cli.device
if args_cli.max_iterations is not None:
    agent_cfg["params"]["config"]["max_epochs"] = args_cli.max_iterations
if args_cli.checkpoint is not None:
    resume_path = os.path.abspath(args_cli.checkpoint)
    print(f"[INFO]: Loading model checkpoint from: {resume_path}")
train_sigma = float(args_cli.sigma) if args_cli.sigma is not None else None

# hydra-style overrides of the agent config, as Isaac Lab takes them (after the flags, so they win):
# agent.params.config.max_epochs=10
for item in overrides:
    key, sep, value = item.partition("=")
    path = key.removeprefix("agent.").split(".")
    if not sep or path[0] != "params":
        parser.error(f"unrecognized argument '{item}' (overrides look like agent.params.config.KEY=VALUE)")
    node = agent_cfg
    for part in path[:-1]:
        node = node.setdefault(part, {})
    node[path[-1]] = yaml.safe_load(value)

# specify directory for logging experiments
log_root_path = os.path.abspath(os.path.join(args_cli.log_root, agent_cfg["params"]["config"]["name"]))
print(f"[INFO] Logging experiment in directory: {log_root_path}")
log_dir = datetime.now().strftime("%Y-%m-%d_%H-%M-%S")
agent_cfg["params"]["config"]["train_dir"] = log_root_path
agent_cfg["params"]["config"]["full_experiment_name"] = log_dir

# read configurations about the agent-training
rl_device = agent_cfg["params"]["config"]["device"]
clip_obs = agent_cfg["params"]["env"].get("clip_observations", math.inf)
clip_actions = agent_cfg["params"]["env"].get("clip_actions", math.inf)

# create the environment and wrap it for rl-games
env = CartpoleDirectEnv(num_envs=args_cli.num_envs or 512, device=rl_device, seed=agent_cfg["params"]["seed"])
env = RlGamesVecEnvWrapper(env, rl_device, clip_obs, clip_actions)

# register the environment to rl-games registry
# note: in agents configuration: environment name must be "rlgpu"
vecenv.register(
    "IsaacRlgWrapper", lambda config_name, num_actors, **kwargs: RlGamesGpuEnv(config_name, num_actors, **kwargs)
)
env_configurations.register("rlgpu", {"vecenv_type": "IsaacRlgWrapper", "env_creator": lambda **kwargs: env})

# set number of actors into agent config
agent_cfg["params"]["config"]["num_actors"] = env.unwrapped.num_envs
# create runner from rl-games
runner = Runner(IsaacAlgoObserver())
runner.load(agent_cfg)

# reset the agent and env
runner.reset()
# train the agent
if args_cli.checkpoint is not None:
    runner.run({"train": True, "play": False, "sigma": train_sigma, "checkpoint": resume_path})
else:
    runner.run({"train": True, "play": False, "sigma": train_sigma})

# close the simulator
env.close()
print(f"[INFO] Run folder: {os.path.join(log_root_path, log_dir)}")
