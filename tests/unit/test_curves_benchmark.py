"""benchmarks/curves.py: the pure functions that turn saved reward events into the comparison table."""

import os
import sys

import pytest
import yaml

from tests.conftest import ROOT

sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
curves = pytest.importorskip("curves")

# (seconds from start, frames, mean reward)
EVENTS = [(10.0, 1000, 1.0), (20.0, 2000, 5.0), (30.0, 3000, 9.0)]


def test_value_at_is_the_last_report_at_or_before_x_on_either_axis():
    assert curves.value_at(EVENTS, 5.0, 0) is None  # nothing reported yet
    assert curves.value_at(EVENTS, 20.0, 0) == 5.0 and curves.value_at(EVENTS, 29.9, 0) == 5.0
    assert curves.value_at(EVENTS, 2999, 1) == 5.0 and curves.value_at(EVENTS, 10**9, 1) == 9.0


def test_mean_std_needs_every_seed():
    assert curves.mean_std([1.0, 3.0]) == (2.0, pytest.approx(2 ** 0.5))
    assert curves.mean_std([1.0, None]) is None and curves.mean_std([4.0]) == (4.0, 0.0)


def test_frame_grid_stops_at_the_frames_every_run_reached():
    runs = {"rlchain": [{"events": EVENTS}], "rl_games": [{"events": [(10.0, 2345, 0.0)]}]}
    assert curves.frame_grid(runs) == [500, 1100, 1700, 2300]  # quarters of 2345, two significant digits


def test_judge_calls_a_gap_only_beyond_both_spreads():
    assert curves.judge((100.0, 10.0), (85.0, 10.0)) == "level"
    assert curves.judge((100.0, 5.0), (85.0, 5.0)) == "ahead"
    assert curves.judge((70.0, 5.0), (85.0, 5.0)) == "behind"
    assert curves.judge(None, (85.0, 5.0)) == "-"


def test_fps_counts_startup():
    assert curves.fps({"events": EVENTS}) == 100.0


def test_seeded_config_sets_both_seeds_and_nothing_else(tmp_path):
    src = os.path.join(ROOT, "benchmarks", curves.CONFIGS["ant"])
    out = curves.seeded_config(src, 17, str(tmp_path))
    with open(src) as f:
        before = yaml.safe_load(f)
    with open(out) as f:
        after = yaml.safe_load(f)
    assert after["params"]["seed"] == 17 and after["params"]["config"]["env_config"]["seed"] == 17
    before["params"]["seed"] = before["params"]["config"]["env_config"]["seed"] = 17
    assert after == before


def test_every_config_of_the_benchmark_is_shipped():
    for path in curves.CONFIGS.values():
        assert os.path.exists(os.path.join(ROOT, "benchmarks", path)), path


def test_splice_replaces_only_the_marked_block():
    doc = "intro\n<!-- curves:begin -->\nold\n<!-- curves:end -->\nrest\n"
    assert curves.splice(doc, "new ![a](curves/a.png)") == ("intro\n<!-- curves:begin -->\nnew ![a](curves/a.png)\n"
                                                             "<!-- curves:end -->\nrest\n")
    with pytest.raises(ValueError, match="markers"):
        curves.splice("no markers", "x")
