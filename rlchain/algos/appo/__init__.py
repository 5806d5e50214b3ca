"""APPO and IMPALA: the algorithm, V-trace fragments, the runner pool and its local and Ray runners."""
