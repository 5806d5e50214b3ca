"""Run output: run folders, checkpoints and the training logs."""
