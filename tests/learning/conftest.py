"""The learning tier's run order under ``--dist worksteal``: the longest tests first on every worker (order.py)."""

import pytest

from tests.learning.order import longest_first, seconds_of


@pytest.hookimpl(trylast=True)  # after ``-m`` / ``-k`` deselected what does not run
def pytest_collection_modifyitems(config, items):
    workers = getattr(config, "workerinput", {}).get("workercount")
    if not workers or config.getoption("dist", None) != "worksteal":
        return  # one process, or another scheduler: collection order
    items[:] = [items[i] for i in longest_first([seconds_of(item.nodeid) for item in items], workers)]
