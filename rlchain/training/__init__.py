"""Training loops and what surrounds them: checkpoints, logs, episode statistics."""
