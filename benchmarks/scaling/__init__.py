"""More workers: torchrun processes, Ray env runners, the asynchronous runner pool."""
