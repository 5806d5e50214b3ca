"""Run output: run folders, checkpoints and the log writers."""
