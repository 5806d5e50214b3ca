"""``--tune`` on Ray Tune (``backend: ray`` in the search file): FIFO, ASHA and population-based
training over rlchain runs, on one machine or a Ray cluster (docs/tuning.md).

Importing this package never imports Ray: :mod:`rlchain.tuning.spec` validates the search file,
:mod:`rlchain.tuning.epochs` paces a run one epoch at a time; :mod:`rlchain.tuning.ray_search` (the
driver) imports Ray when a search starts, :mod:`rlchain.tuning.trainable` (a trial) at import.
"""
