"""The learning tier's worksteal order (tests/learning/order.py, tests/learning/conftest.py) and the replay that
compares orders (tests/tools/worksteal_order.py)."""

from types import SimpleNamespace

from tests.learning import conftest as learning_conftest
from tests.learning.order import SECONDS, longest_first, seconds_of, share_sizes
from tests.tools.worksteal_order import replay


def test_share_sizes_follow_xdists_first_hand_out():
    assert share_sizes(5, 2) == [2, 3]
    assert share_sizes(7, 3) == [2, 2, 3]
    assert share_sizes(1, 2) == [0, 1]
    assert sum(share_sizes(57, 2)) == 57


def test_each_share_starts_with_a_long_test_and_balances_the_work():
    seconds = [1.0, 50.0, 3.0, 0.0, 0.0, 90.0, 2.0, 40.0]
    order = longest_first(seconds, 2)
    assert sorted(order) == list(range(len(seconds)))
    first, second = order[:4], order[4:]  # share_sizes(8, 2) == [4, 4]
    assert seconds[first[0]] == 90.0 and seconds[second[0]] == 50.0
    for share in (first, second):
        assert [seconds[i] for i in share] == sorted((seconds[i] for i in share), reverse=True)
    assert abs(sum(seconds[i] for i in first) - sum(seconds[i] for i in second)) <= 40.0


def test_unmeasured_tests_keep_their_order_after_the_measured_ones():
    order = longest_first([0.0, 5.0, 0.0, 0.0], 1)
    assert order == [1, 0, 2, 3]


def test_longest_first_ends_sooner_than_a_late_long_test():
    # collection order puts the long test last: one worker runs it alone at the end
    seconds = [10.0] * 10 + [100.0]
    in_collection, _ = replay(seconds, 2)
    ordered, _ = replay([seconds[i] for i in longest_first(seconds, 2)], 2)
    assert in_collection == 150.0  # the 100 s test starts at 50 s, after the other worker's five 10 s ones
    assert ordered == 110.0  # it starts first; the test queued right behind it is the only one not stolen


def test_replay_steals_from_the_busiest_queue():
    # worker 0: a 100 s test and four 10 s ones; worker 1: six 10 s ones. Down to its last test at 50 s, worker 1
    # takes the last two of worker 0's queue, at 70 s one more; the one right behind the running test stays
    assert replay([100.0] + [10.0] * 10, 2) == (110.0, 90.0)
    # worker 0: six 10 s tests; worker 1: a 100 s one, then five 1 s ones. Down to its last test at 50 s, worker 0
    # takes three of worker 1's 1 s tests, at 62 s one more; worker 1 keeps the one behind its running test
    assert replay([10.0] * 6 + [100.0] + [1.0] * 5, 2) == (101.0, 64.0)


def test_the_hook_orders_only_a_worksteal_worker(monkeypatch):
    monkeypatch.setitem(SECONDS, "a.py::long", 100.0)
    monkeypatch.setitem(SECONDS, "a.py::mid", 50.0)
    items = [SimpleNamespace(nodeid=name) for name in ("a.py::short", "a.py::mid", "a.py::long[x]", "a.py::new")]

    def config(dist, workerinput=None):
        cfg = SimpleNamespace(getoption=lambda name, default=None: dist)
        if workerinput is not None:
            cfg.workerinput = workerinput
        return cfg

    serial = list(items)
    learning_conftest.pytest_collection_modifyitems(config("no"), serial)
    assert serial == items
    other = list(items)
    learning_conftest.pytest_collection_modifyitems(config("loadfile", {"workercount": 2}), other)
    assert other == items
    ordered = list(items)
    learning_conftest.pytest_collection_modifyitems(config("worksteal", {"workercount": 2}), ordered)
    assert [item.nodeid for item in ordered] == ["a.py::long[x]", "a.py::new", "a.py::mid", "a.py::short"]
    assert seconds_of("a.py::long[x]") == 100.0 and seconds_of("a.py::short") == 0.0
