"""Stand-in for Isaac Lab's ``isaaclab`` package: what its rl_games scripts import, on a CPU."""
