"""``--tune``: Optuna (in-process trials) and Ray Tune (FIFO, ASHA, population-based training, one machine or a
cluster) as two backends over one shared module (docs/tuning.md).

:mod:`rlchain.tuning.common` reads the search file; :mod:`rlchain.tuning.search` picks the backend;
:mod:`rlchain.tuning.optuna_search` and :mod:`rlchain.tuning.ray_search` run it. Importing this package never
imports Ray or Optuna: :mod:`rlchain.tuning.spec` validates the Ray keys, :mod:`rlchain.tuning.epochs` paces a run
one epoch at a time; ray_search imports Ray when a search starts, :mod:`rlchain.tuning.trainable` (a trial) at import.
"""
