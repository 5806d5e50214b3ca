"""Steps per second: env-only, rollout and train per case, CPU time per epoch, one tree against another."""
