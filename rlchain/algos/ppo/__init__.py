"""PPO (rl_games' a2c_continuous / a2c_discrete): the algorithm, its agent, rollout collection and the central value."""
