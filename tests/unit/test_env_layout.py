"""env_groups: auto on envpool: which layout the measurements choose (rlchain.algos.ppo.env_layout)."""

import pytest

from rlchain.algos.ppo.env_layout import MARGIN, ONE_POOL, TWO_POOLS, PipelineChoice, fastest, measure_layouts


def test_two_pools_unless_one_pool_is_faster_by_the_margin():
    two = [1.0, 1.0, 1.0]
    assert fastest({ONE_POOL: [1.0 - MARGIN / 2, 0.5, 5.0], TWO_POOLS: two}) is TWO_POOLS  # within the margin
    assert fastest({ONE_POOL: [1.0 - 2 * MARGIN] * 3, TWO_POOLS: two}) is ONE_POOL
    assert fastest({ONE_POOL: [0.5, 1.2, 1.3], TWO_POOLS: two}) is TWO_POOLS  # medians, not means or minima
    assert fastest({ONE_POOL: [1.0] * 3, TWO_POOLS: [0.8] * 3}) is TWO_POOLS


def feed(choice, times):
    """Run rollouts as the trainer does: ask which way, then report its seconds; the ways asked for."""
    asked = []
    for together, piped in times:
        way = choice.pipelined()
        asked.append(way)
        choice.record(way, piped if way else together)
    return asked


def test_explicit_env_groups_always_pipeline():
    choice = PipelineChoice(auto=False)
    assert feed(choice, [(1.0, 9.0)] * 8) == [True] * 8


@pytest.mark.parametrize("together,piped,decided", [(1.0, 0.9, True), (1.0, 1.0, False), (1.0, 1.2, False)])
def test_auto_alternates_then_keeps_the_faster(together, piped, decided):
    choice = PipelineChoice(auto=True, trials=3)
    asked = feed(choice, [(together, piped)] * 10)
    # the first rollout warms up (not timed), then 3 timed rollouts each way in turn, then the choice
    assert asked[:7] == [True, False, True, False, True, False, True]
    assert asked[7:] == [decided] * 3 and choice.decided is decided
    assert choice.seconds == {False: [together] * 3, True: [piped] * 3}


def test_auto_decides_on_medians():
    choice = PipelineChoice(auto=True, trials=3)
    feed(choice, [(0, 0), (1.0, 0), (0, 0.5), (1.0, 0), (0, 3.0), (1.0, 0), (0, 0.6)])  # one slow pipelined outlier
    assert choice.decided is True


class CountingStepper:
    def __init__(self, layout, seconds_per_step, clock):
        self.layout, self.per_step, self.clock, self.count = layout, seconds_per_step, clock, 0

    def steps(self, count):
        self.count += count
        self.clock[0] += count * self.per_step


def test_measure_layouts_times_each_layout_in_turn(monkeypatch):
    clock = [0.0]
    monkeypatch.setattr("rlchain.algos.ppo.env_layout.time.perf_counter", lambda: clock[0])
    one, two = CountingStepper(ONE_POOL, 0.001, clock), CountingStepper(TWO_POOLS, 0.01, clock)
    seconds = measure_layouts([one, two], rounds=4, round_seconds=0.05)
    assert seconds == {ONE_POOL: pytest.approx([0.001] * 4), TWO_POOLS: pytest.approx([0.01] * 4)}
    assert one.count == 2 + 4 * 50 and two.count == 2 + 4 * 5  # warm-up, then about round_seconds per round
