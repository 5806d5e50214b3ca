"""Env backends: gymnasium, envpool, brax, playground, PettingZoo, tensor envs, jax, Atari, rl_games IVecEnvs."""
