"""Env backends: one module per kind of vectorized env."""
