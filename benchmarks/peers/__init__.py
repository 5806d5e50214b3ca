"""Against the peers: rl_games 1.6.5 / 2.0 and Stable-Baselines3 on the same configs (learning curves, drivers)."""
