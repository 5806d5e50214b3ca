"""benchmarks/curves.py: the pure functions that turn saved reward events into the comparison table."""

import json
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


def test_time_to_is_the_first_report_at_or_above_the_target():
    assert curves.time_to(EVENTS, 5.0) == 20.0 and curves.time_to(EVENTS, 9.5) is None


def test_reach_cell_counts_a_seed_that_never_reached_as_later_than_all():
    assert curves.reach_cell([10.0, 30.0, None]) == "30 s (2/3)"
    assert curves.reach_cell([10.0, None, None]) == "not reached (1/3)"
    assert curves.reach_cell([None]) == "not reached (0/1)"


def test_every_peer_names_its_version_and_setting():
    # OMP_NUM_THREADS=1 left rl_games at 2 torch threads: the label says so (its saved runs keep their old one)
    assert curves.describe("rl_games") == "rl_games 1.6.5, OMP_NUM_THREADS=1 (2 torch threads), compile off"
    assert curves.describe("rl_games2_shipped").startswith("rl_games 2.0 (main), as shipped")
    best = curves.SYSTEMS["rl_games"]
    assert dict(best.env)["OMP_NUM_THREADS"] == "1" and best.driver_args == ("--torch-compile", "off")
    one = curves.SYSTEMS["rl_games2_tt1"]  # rl_games sets its own torch threads: only torch_threads: 1 is one
    assert one.lib == "rl_games2" and one.driver_args[-2:] == ("--torch-threads", "1")


def test_summary_compares_rlchain_with_each_peer_and_the_time_to_their_final_reward():
    runs = {"rlchain": [{"events": EVENTS}, {"events": EVENTS}],
            "rl_games": [{"events": [(15.0, 1000, 2.0), (30.0, 2000, 4.0)]}] * 2,
            "rl_games2": [{"events": [(15.0, 1000, 3.0), (30.0, 2000, 6.0)]}] * 2}
    text = "\n".join(curves.summarise("hopper", runs, 30.0))
    assert "rlchain / rl_games | rlchain / rl_games2" in text
    # rlchain reached rl_games' final 4 at 20 s, rl_games at 30 s, rl_games2 (3 at 15 s, then 6) at 30 s
    assert "| hopper | rl_games at 30 s: 4 | 20 s (2/2) | 30 s (2/2) | 30 s (2/2) | 1.50x | 1.50x |" in text
    # rl_games2's final 6: rlchain at 30 s (9), rl_games never (4)
    assert "| hopper | rl_games2 at 30 s: 6 | 30 s (2/2) | not reached (0/2) | 30 s (2/2) | > budget | 1.00x |" in text


def test_reach_cell_gives_the_spread_of_the_seeds_that_reached():
    assert curves.reach_cell([10.0, 30.0, 50.0, None], spread=True) == "40 s [10-50] (3/4)"
    assert curves.reach_cell([12.0], spread=True) == "12 s (1/1)"


def test_time_to_reward_table_spans_configs_and_marks_missing_systems():
    fast = [{"events": [(10.0, 1000, 5.0)]}] * 3
    slow = [{"events": [(10.0, 1000, 1.0), (40.0, 4000, 5.0)]}] * 3
    rows = [("hopper", {"rlchain": fast, "rl_games": slow, "rl_games2": slow}, 40.0),
            ("ant", {"rlchain": slow, "rl_games": fast}, 40.0)]
    lines = curves.time_to_reward_table(rows)
    assert lines[0] == ("| YAML | target: mean reward | rlchain | rl_games | rl_games2 | rl_games / rlchain "
                        "| rl_games2 / rlchain |")
    assert "| hopper | rl_games at 40 s: 5 | 10 s (3/3) | 40 s (3/3) | 40 s (3/3) | 4.00x | 4.00x |" in lines
    assert "| ant | rl_games at 40 s: 5 | 40 s (3/3) | 10 s (3/3) | - | 0.25x | - |" in lines
    assert not any(line.startswith("| ant | rl_games2") for line in lines)  # no rl_games2 runs: no target


def test_saved_runs_of_another_setting_are_not_loaded(tmp_path):
    path = curves.run_path(str(tmp_path), "hopper", "rl_games", 11)
    os.makedirs(os.path.dirname(path))
    shipped = {"budget_s": 180.0, "events": EVENTS, "env": {}, "setting": "as shipped"}  # an old as-shipped run
    with open(path, "w") as f:
        json.dump(shipped, f)
    assert curves.load_runs(str(tmp_path), "hopper", ["rl_games"], [11], 180.0)["rl_games"] == []
    best = dict(shipped, env=dict(curves.SYSTEMS["rl_games"].env), setting="1 thread, compile off")  # saved_as
    with open(path, "w") as f:
        json.dump(best, f)
    assert len(curves.load_runs(str(tmp_path), "hopper", ["rl_games"], [11], 180.0)["rl_games"]) == 1
    relabelled = dict(best, setting=curves.SYSTEMS["rl_games"].setting)  # the display text is not the key
    with open(path, "w") as f:
        json.dump(relabelled, f)
    assert curves.load_runs(str(tmp_path), "hopper", ["rl_games"], [11], 180.0)["rl_games"] == []


def test_iqm_table_is_rlchain_compare_on_the_saved_runs():
    runs = {"rlchain": [{"events": [(10.0, 1000, float(v)), (30.0, 3000, float(v))], "seed": s, "config": "hopper",
                         "budget_s": 30.0} for s, v in ((11, 1), (12, 2), (13, 3), (14, 100))],
            "rl_games": [{"events": [(15.0, 2000, 4.0)], "seed": 11, "config": "hopper", "budget_s": 30.0}]}
    text = "\n".join(curves.iqm_table("hopper", runs, 30.0))
    assert "| at | rlchain, as shipped | rl_games 1.6.5, OMP_NUM_THREADS=1 (2 torch threads), compile off |" in text
    # at 30 s (the budget: the runs went on to it) rlchain's IQM of 1, 2, 3, 100 is 2.5; rl_games has one seed
    row = next(line for line in text.splitlines() if line.startswith("| 30 s |"))
    assert row.split("|")[2].strip().startswith("2.5 [") and row.endswith("| 4 [4, 4] (1/1) |")
    # frames: quarters of the 2000 frames every run reached; rl_games had reported nothing by 500
    assert "| 2k frames | 2.5 [" in text and text.split("| 500 frames |")[1].split("\n")[0].endswith("- (0/1) |")


def test_a_frame_budget_caps_each_library_in_its_own_terms(tmp_path):
    # issue 32: reward per frame compared on a loaded machine needs a frame budget, not a time budget
    cfg = os.path.join(curves.HERE, curves.CONFIGS["hopper"])  # horizon_length 64 x num_actors 64 per epoch
    assert curves.frame_cap_args("rlchain", cfg, 1_000_000) == ["params.config.max_frames=1000000"]
    assert curves.frame_cap_args("rl_games", cfg, 1_000_000) == ["--max-epochs", "245"]  # 245 * 4096 >= 1M
    assert curves.frame_cap_args("rl_games2", cfg, 4096) == ["--max-epochs", "1"]
    assert curves.frame_cap_args("rl_games", cfg, None) == []
    args = curves.parse_args(["--frames", "8192", "--libs", "rlchain", "rl_games"])
    assert curves.command("rlchain", cfg, args)[-1] == "params.config.max_frames=8192"
    assert curves.command("rl_games", cfg, args)[-2:] == ["--max-epochs", "2"]


def test_frames_must_be_positive(capsys):
    with pytest.raises(SystemExit):
        curves.parse_args(["--frames", "0"])
    assert "--frames must be a positive number of env frames, got 0" in capsys.readouterr().err


def test_saved_runs_of_another_frame_budget_are_not_loaded(tmp_path):
    path = curves.run_path(str(tmp_path), "hopper", "rlchain", 11)
    os.makedirs(os.path.dirname(path))
    with open(path, "w") as f:
        json.dump({"budget_s": 900.0, "budget_frames": 1_000_000, "events": EVENTS, "env": {}}, f)
    assert curves.load_runs(str(tmp_path), "hopper", ["rlchain"], [11], 900.0)["rlchain"] == []
    assert curves.load_runs(str(tmp_path), "hopper", ["rlchain"], [11], 900.0, 500_000)["rlchain"] == []
    assert len(curves.load_runs(str(tmp_path), "hopper", ["rlchain"], [11], 900.0, 1_000_000)["rlchain"]) == 1
    skipped = []  # what --plot-only prints instead of silently plotting nothing
    curves.load_runs(str(tmp_path), "hopper", ["rlchain"], [11], 180.0, None, skipped)
    assert skipped == [f"{path}: saved with --seconds 900 --frames 1000000, asked for --seconds 180 --frames None"]


def test_bf16_system_is_rlchain_with_its_override_and_tensor_envs_reach_rl_games_through_its_vecenv(tmp_path):
    args = curves.parse_args(["--libs", "rlchain", "rlchain_bf16", "rl_games2"])
    cfg = os.path.join(curves.HERE, curves.CONFIGS["hopper"])
    assert "params.config.mixed_precision=bf16" in curves.command("rlchain_bf16", cfg, args)
    assert "params.config.mixed_precision=bf16" not in curves.command("rlchain", cfg, args)
    compiled = curves.command("rlchain_compiled", cfg, curves.parse_args(["--libs", "rlchain_compiled"]))
    assert "params.config.compile_update=True" in compiled and "params.config.torch_compile=True" in compiled
    assert "--tensor-env" in curves.command("rl_games2", cfg, args, tensor_env=True)
    assert "--tensor-env" not in curves.command("rl_games2", cfg, args)
    assert curves.budget_of("torch_pendulum", args) == 30.0 and curves.budget_of("hopper", args) == 300.0


def test_tensor_env_runs_train_for_the_whole_budget(tmp_path):
    src = os.path.join(curves.HERE, curves.CONFIGS["torch_pendulum"])
    with open(curves.seeded_config(src, 12, str(tmp_path), whole_budget=True)) as f:
        config = yaml.safe_load(f)["params"]
    assert config["seed"] == 12 and "score_to_win" not in config["config"]
