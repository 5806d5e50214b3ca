"""Stand-in for ``isaaclab_tasks``: registers the cart-pole task with gymnasium, as Isaac Lab's tasks do."""

import gymnasium as gym

gym.register(
    id="Isaac-Cartpole-Standin-Direct-v0",
    entry_point="isaaclab.envs:CartpoleStandinEnv",
    disable_env_checker=True,
    kwargs={"env_cfg_entry_point": "isaaclab.envs:DirectRLEnvCfg",
            "rl_games_cfg_entry_point": "isaaclab_tasks.cartpole.agents:rl_games_ppo_cfg.yaml"},
)

gym.register(
    id="Isaac-Cartpole-Standin-Asym-Direct-v0",
    entry_point="isaaclab.envs:CartpoleAsymStandinEnv",
    disable_env_checker=True,
    kwargs={"env_cfg_entry_point": "isaaclab.envs:DirectRLEnvCfg",
            "rl_games_cfg_entry_point": "isaaclab_tasks.cartpole.agents:rl_games_ppo_asym_cfg.yaml"},
)
