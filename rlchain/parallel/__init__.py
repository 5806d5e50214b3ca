"""Parallelism below the algorithms: the communicator (no-op or torch.distributed), torchrun setup, thread plans."""
