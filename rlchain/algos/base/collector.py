"""The on-policy collector's old import path: it lives in :mod:`rlchain.algos.core.collector`."""

from rlchain.algos.core import collector as _collector
from rlchain.deprecation import renamed

__getattr__ = renamed(__name__, {
    name: (f"rlchain.algos.core.collector.{name}", getattr(_collector, name))
    for name in ("OnPolicyCollector", "CollectedStep", "ActFn", "PipelineChoice", "AlwaysPipelined")
})
