"""Run output: run folders, checkpoints, the training logs and their writers."""
