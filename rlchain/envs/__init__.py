"""Environments: the VecEnv contract, backends (gymnasium, envpool) and the env registry."""
