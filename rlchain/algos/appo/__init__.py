"""APPO and IMPALA: the trainer, V-trace fragments, the runner pool and its local and Ray runners."""
