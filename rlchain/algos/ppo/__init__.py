"""PPO (rl_games' a2c_continuous / a2c_discrete): the agent, its trainer, rollout collection and the central value."""
