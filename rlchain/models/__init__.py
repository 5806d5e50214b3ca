"""Policy models: distributions, normalizers and the actor-critic wrapper around a network."""
