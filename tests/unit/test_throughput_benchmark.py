"""benchmarks/throughput.py: thread plans and the deliberate background load of the plan comparison."""

import os
import sys
import time

import pytest

from tests.conftest import ROOT

sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
throughput = pytest.importorskip("throughput")


def test_parse_plan_reads_auto_and_rollout_update_pairs():
    assert throughput.parse_plan("auto") == ("auto", None, None)
    assert throughput.parse_plan("1/2") == ("1/2", 1, 2)
    with pytest.raises(SystemExit, match="bad plan '2'"):
        throughput.parse_plan("2")


def test_busy_processes_run_inside_the_block_and_are_gone_after():
    with throughput.busy_processes(1):
        time.sleep(0.05)
        import multiprocessing
        children = multiprocessing.active_children()
        assert len(children) == 1 and children[0].is_alive()
    assert multiprocessing.active_children() == []
