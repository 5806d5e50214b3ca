"""What every algorithm and the training loop share: the Algorithm protocol, the run context, the
safety checks and the episode statistics."""
