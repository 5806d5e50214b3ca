"""Env backends: gymnasium, envpool, brax, playground, PettingZoo, tensor envs, jax batching, Atari."""
