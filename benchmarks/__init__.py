"""rlchain's benchmark scripts, grouped by the question each answers (README.md is the index).

A package so that the scripts share ``benchmarks/common.py`` and the tests import them by name
(``from benchmarks.throughput import throughput``). Every script also runs by its path from the
repository root (``python benchmarks/throughput/throughput.py``) or as a module
(``python -m benchmarks.throughput.throughput``).
"""
