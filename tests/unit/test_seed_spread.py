"""tests/tools/seed_spread.py's reading of a seed's reports: the junit verdicts, where a reward curve passed a bar."""

from tests.tools import seed_spread

JUNIT = """<?xml version="1.0" encoding="utf-8"?><testsuites><testsuite name="pytest">
<testcase classname="tests.learning.test_a" name="test_learns" time="12.5"/>
<testcase classname="tests.learning.test_a" name="test_fails[x]" time="3.0"><failure message="no"/></testcase>
<testcase classname="tests.learning.test_b" name="test_needs_jax" time="0.0"><skipped message="jax"/></testcase>
</testsuite></testsuites>"""


def test_junit_verdicts_are_keyed_by_node_id(tmp_path):
    path = tmp_path / "seed_1.xml"
    path.write_text(JUNIT)
    assert seed_spread.outcomes(str(path)) == {
        "tests/learning/test_a.py::test_learns": ("passed", 12.5),
        "tests/learning/test_a.py::test_fails[x]": ("failed", 3.0),
        "tests/learning/test_b.py::test_needs_jax": ("skipped", 0.0),
    }
    assert seed_spread.outcomes(str(tmp_path / "missing.xml")) == {}


def test_a_bar_is_reached_at_the_first_epoch_at_or_above_it():
    curve = [[2048, 20.0], [4096, 310.0], [6144, 290.0], [8192, 460.0]]
    assert seed_spread.reached(curve, 300) == "4.1k"
    assert seed_spread.reached(curve, 450) == "8.2k"
    assert seed_spread.reached(curve, 500) == "-"


def test_a_cell_names_each_run_and_the_bars():
    run = {"frames": 135168, "stop": "score_to_win 450.0 reached", "mean_reward": 450.44,
           "curve": [[92160, 300.9], [135168, 450.44]]}
    assert seed_spread.cell("passed", 42.0, [run], [300]) == "passed: 135.2k (score_to_win, 450, 300 at 92.2k) 42 s"
    played = seed_spread.cell("passed", 9.0, [run, {"played": 274.0}], [])
    assert played == "passed: 135.2k (score_to_win, 450); played 274 9 s"
    assert seed_spread.cell("failed", 1.0, [], []) == "failed: no Runner run 1 s"
    assert seed_spread.cell("skipped", 0.0, [], []) == "skipped"


def test_the_command_line_keeps_test_ids_after_the_lists():
    args, tests = seed_spread.parse_args(["--seeds", "default,1,2", "tests/learning/test_a.py", "--reach", "300,400",
                                          "-k", "cartpole", "tests/learning/test_b.py::test_learns"])
    assert args.seeds == ["default", "1", "2"] and args.reach == [300.0, 400.0]
    assert tests == ["tests/learning/test_a.py", "-k", "cartpole", "tests/learning/test_b.py::test_learns"]
    args, tests = seed_spread.parse_args(["tests/learning"])
    assert args.seeds == ["default", "1", "2"] and args.reach == [] and tests == ["tests/learning"]


def test_the_old_space_separated_seeds_are_one_clear_error(capsys):
    import pytest

    with pytest.raises(SystemExit):
        seed_spread.parse_args(["--seeds", "default", "1", "2", "tests/learning/test_a.py"])
    assert "1 2: not a test id; --seeds and --reach take one comma-separated list" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        seed_spread.parse_args(["--reach", "high", "tests/learning"])
