"""Algorithms: pure return/loss math, rollout storage, schedules and the PPO agent."""
