"""The benchmark scripts (benchmarks/, a package): each imports, runs by its path, and the logic a comparison
stands on holds: the peers' thread and compile settings, the time-to-reward table, the YAML copies each run
trains, a base tree of either layout. Pure functions and fake interpreters: no peer library is installed here."""

import json
import os
import subprocess
import sys
import time
from importlib import import_module

import numpy as np
import pytest
import yaml

from benchmarks import common
from benchmarks.peers import curves, her_vs_sb3, rl_games_driver, rl_games_tensor_env, sb3_her_driver
from benchmarks.studies import push_cube_eval
from benchmarks.throughput import epoch_cpu, off_policy_step_time, throughput, tree_compare
from rlchain.envs.wrappers.goal_env import fetch_compute_reward
from tests.conftest import CONFIGS, ROOT

SCRIPTS = sorted(os.path.relpath(os.path.join(folder, name), ROOT)
                 for folder, _, names in os.walk(os.path.join(ROOT, "benchmarks"))
                 for name in names if name.endswith(".py") and name != "__init__.py" and "results" not in folder)


@pytest.mark.parametrize("script", SCRIPTS)
def test_every_script_imports_by_its_package_name(script):
    """A renamed rlchain module or a moved script breaks here, not the next time someone benchmarks."""
    name = script[:-3].replace(os.sep, ".")
    try:
        import_module(name)
    except ModuleNotFoundError as exc:  # an optional library (ray, envpool, a peer's) is not installed here
        if exc.name and exc.name.split(".")[0] in ("rlchain", "benchmarks"):
            raise
        pytest.skip(f"{name} needs {exc.name}")


def test_a_script_runs_by_its_path_from_anywhere(tmp_path):
    """``python benchmarks/<folder>/<script>.py`` finds benchmarks.common without PYTHONPATH or the repo as cwd."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run([sys.executable, os.path.join(ROOT, "benchmarks", "throughput", "tree_compare.py"),
                          "--base", "no-such-revision-xyz"], capture_output=True, text=True, cwd=tmp_path, env=env,
                         timeout=60)
    assert out.returncode != 0 and out.stderr.strip().splitlines()[-1].startswith(
        "tree_compare.py: --base no-such-revision-xyz: no worktree"), out.stderr


def test_a_base_tree_of_either_layout_finds_its_throughput_script(tmp_path):
    (tmp_path / "benchmarks").mkdir()
    assert common.throughput_script(str(tmp_path)) == str(tmp_path / "benchmarks" / "throughput.py")
    (tmp_path / "benchmarks" / "throughput").mkdir()
    (tmp_path / "benchmarks" / "throughput" / "throughput.py").write_text("")
    assert common.throughput_script(str(tmp_path)) == str(tmp_path / "benchmarks" / "throughput" / "throughput.py")
    assert common.throughput_script(ROOT) == os.path.join(ROOT, "benchmarks", "throughput", "throughput.py")


def test_results_go_outside_git(tmp_path, monkeypatch):
    monkeypatch.setenv("RLCHAIN_BENCH_RESULTS", str(tmp_path))
    assert common.results_dir("curves") == str(tmp_path / "curves")
    with open(os.path.join(ROOT, ".gitignore")) as fh:
        assert "benchmarks/results/" in fh.read().split()


# ----- throughput.py and the rl_games driver it runs ------------------------------------------------
def test_parse_plan_reads_auto_and_rollout_update_pairs():
    assert throughput.parse_plan("auto") == ("auto", None, None)
    assert throughput.parse_plan("1/2") == ("1/2", 1, 2)
    with pytest.raises(SystemExit, match="bad plan '2'"):
        throughput.parse_plan("2")


def test_env_groups_values_and_layout_labels():
    from types import SimpleNamespace
    assert throughput.parse_groups("auto") == "auto" and throughput.parse_groups("2") == 2
    with pytest.raises(SystemExit, match="bad --env-groups value 'two'"):
        throughput.parse_groups("two")
    ppo = SimpleNamespace(collector=SimpleNamespace(pipeline_choice=SimpleNamespace(decided=True)))
    two, one = SimpleNamespace(pools=[0, 1]), SimpleNamespace(pools=[0])
    assert throughput.layout_label(two, ppo, auto=True) == "a2p" and throughput.layout_label(one, ppo, True) == "a1"
    ppo.collector.pipeline_choice.decided = False
    assert throughput.layout_label(two, ppo, auto=False) == "2t"


def test_parse_variant_reads_a_label_and_its_overrides():
    assert throughput.parse_variant("base=") == ("base", ())
    assert throughput.parse_variant("bf16+c=params.config.mixed_precision=bf16,params.config.compile_update=True") \
        == ("bf16+c", ("params.config.mixed_precision=bf16", "params.config.compile_update=True"))
    for bad in ("bf16", "=a=b", "x=params.config.mixed_precision"):
        with pytest.raises(SystemExit, match="bad variant"):
            throughput.parse_variant(bad)


def test_table_gives_each_variant_its_ratio_to_the_first():
    rows = [throughput.Row("torch", "TorchPendulum-v0", 64, 1e6, 5e5, 2e5, 1, "c.yaml", variant="base"),
            throughput.Row("torch", "TorchPendulum-v0", 64, 1e6, 5e5, 3e5, 1, "c.yaml", variant="bf16",
                           warmup_s=9.5, base_train_sps=2e5)]
    lines = throughput.table(rows).splitlines()
    assert lines[2].split()[-3:] == ["base", "0.0", "-"] and lines[3].split()[-3:] == ["bf16", "9.5", "1.50"]


def test_busy_processes_run_inside_the_block_and_are_gone_after():
    with throughput.busy_processes(1):
        time.sleep(0.05)
        import multiprocessing
        children = multiprocessing.active_children()
        assert len(children) == 1 and children[0].is_alive()
    assert multiprocessing.active_children() == []


def test_rl_games_peers_are_one_column_per_version_and_compile_setting():
    args = throughput.argparse.Namespace(rl_games_python="/a/python", rl_games2_python="/b/python",
                                         rl_games_compile=["off", "config"])
    peers = throughput.rl_games_peers(args)
    assert [(p.label, p.python, p.compile) for p in peers] == [
        ("rlg1.6.5", "/a/python", "off"), ("rlg1.6.5+compile", "/a/python", "config"),
        ("rlg2.0", "/b/python", "off"), ("rlg2.0+compile", "/b/python", "config")]
    args.rl_games_python = None  # a version without a venv is not measured
    assert [p.label for p in throughput.rl_games_peers(args)] == ["rlg2.0", "rlg2.0+compile"]


def test_table_gives_each_peer_its_steps_and_rlchains_ratio_and_a_dash_where_it_failed():
    rows = [throughput.Row("torch", "TorchCartPole-v0", 4096, 1e7, 4e6, 2e6, 1, "c.yaml",
                           peers={"rlg1.6.5": 5e5, "rlg2.0": None})]
    text = throughput.table(rows)
    head, _, line = text.splitlines()
    assert "rlg1.6.5 sps" in head and "train/rlg2.0" in head
    assert line.split()[-4:] == ["500,000", "4.00", "-", "-"]


def test_the_tensor_env_for_rl_games_is_rlchains_own_env():
    env = rl_games_tensor_env.make_env("TorchCartPole-v0", 8, device="cpu", seed=3)
    assert env.num_envs == 8 and tuple(env.reset().shape) == (8, 4)


def test_rl_games_driver_scales_the_minibatch_with_num_actors_and_names_silu_as_rl_games_does(tmp_path):
    cfg = {"params": {"network": {"mlp": {"activation": "silu"}},
                      "config": {"num_actors": 1024, "horizon_length": 32, "minibatch_size": 4096,
                                 "env_config": {"device": "cpu"}}}}
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    args = rl_games_driver.parse_args(["--file", str(path), "--num-actors", "4096", "--device", "cuda:0"])
    out = rl_games_driver.load_config(args)["params"]
    assert out["config"]["num_actors"] == 4096 and out["config"]["minibatch_size"] == 16384  # still 8 minibatches
    assert out["config"]["env_config"]["device"] == "cuda:0" and out["network"]["mlp"]["activation"] == "swish"


def test_rl_games_driver_sets_rl_games_own_thread_count(tmp_path):
    # rl_games calls torch.set_num_threads(params.torch_threads or min(4, cores)): OMP_NUM_THREADS=1 is not one thread
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump({"params": {"config": {"num_actors": 8}}}))
    unset = rl_games_driver.load_config(rl_games_driver.parse_args(["--file", str(path)]))["params"]
    assert "torch_threads" not in unset
    args = rl_games_driver.parse_args(["--file", str(path), "--torch-threads", "1"])
    assert rl_games_driver.load_config(args)["params"]["torch_threads"] == 1


def test_rl_games_driver_leaves_a_per_env_minibatch_to_scale_by_itself(tmp_path):
    cfg = {"params": {"config": {"num_actors": 64, "horizon_length": 32, "minibatch_size_per_env": 8}}}
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    out = rl_games_driver.load_config(rl_games_driver.parse_args(["--file", str(path), "--num-actors", "256"]))
    assert out["params"]["config"] == {"num_actors": 256, "horizon_length": 32, "minibatch_size_per_env": 8}


def test_rl_games_is_not_run_on_a_yaml_whose_env_is_not_the_cases(tmp_path, capsys):
    path = tmp_path / "c.yaml"
    path.write_text("params:\n  config:\n    env_name: TorchPendulum-v0\n")
    assert throughput.rl_games_fps("/no/python", str(path), "TorchCartPole-v0", 64, 3, "torch") is None
    assert "its env is TorchPendulum-v0, the case's is TorchCartPole-v0" in capsys.readouterr().out


def test_a_peer_python_that_is_not_there_is_one_line_not_a_traceback(tmp_path, capsys):
    path = tmp_path / "c.yaml"
    path.write_text("params:\n  config:\n    env_name: TorchCartPole-v0\n")
    assert throughput.rl_games_fps(str(tmp_path / "no-python"), str(path), "TorchCartPole-v0", 64, 3, "torch") is None
    assert "no-python: No such file or directory" in capsys.readouterr().out


def test_rl_games_gets_one_torch_thread_through_its_own_setting(tmp_path):
    # OMP_NUM_THREADS=1 alone left rl_games at min(4, cores) threads: the driver must pass params.torch_threads
    path = tmp_path / "c.yaml"
    path.write_text("params:\n  config:\n    env_name: TorchCartPole-v0\n")
    seen = tmp_path / "seen"
    fake = tmp_path / "python"
    fake.write_text(f'#!/bin/sh\necho "$@ OMP=$OMP_NUM_THREADS" > {seen}\n'
                    'printf "fps total: 10\\nfps total: 20\\nfps total: 40\\n"\n')
    fake.chmod(0o755)
    assert throughput.rl_games_fps(str(fake), str(path), "TorchCartPole-v0", 64, 3, "torch") == 30.0
    args = seen.read_text().split()
    assert args[args.index("--torch-threads") + 1] == "1" and "OMP=1" in args
    throughput.rl_games_fps(str(fake), str(path), "TorchCartPole-v0", 64, 3, "torch", threads=2)
    args = seen.read_text().split()
    assert args[args.index("--torch-threads") + 1] == "2" and "OMP=2" in args


def test_rl_games_threads_must_be_a_positive_int():
    assert throughput.parse_threads("2") == 2
    for bad in ("0", "-1", "two"):
        with pytest.raises(SystemExit, match=f"bad --rl-games-threads value '{bad}': expected an int >= 1"):
            throughput.parse_threads(bad)


# ----- curves.py: the time-to-reward comparison ----------------------------------------------------
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
    src = os.path.join(curves.HERE, curves.CONFIGS["ant"])
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
        assert os.path.exists(os.path.join(curves.HERE, path)), path


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
    # reward per frame compared on a loaded machine needs a frame budget, not a time budget
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


# ----- her_vs_sb3.py and sb3_her_driver.py ---------------------------------------------------------
# (seconds from start, frames, success rate)
FAST = [(10.0, 200, 0.0), (20.0, 400, 0.5), (30.0, 600, 0.9)]
SLOW = [(20.0, 200, 0.0), (40.0, 400, 0.1), (60.0, 600, 0.8)]


def test_first_reach_is_the_first_report_at_or_above_the_target():
    assert her_vs_sb3.first_reach(FAST, 0.5) == (20.0, 400)
    assert her_vs_sb3.first_reach(SLOW, 0.8) == (60.0, 600)
    assert her_vs_sb3.first_reach(SLOW, 0.9) is None


def test_run_config_sets_seeds_and_budget_turns_success_to_win_off_and_nothing_else(tmp_path):
    path = os.path.join(CONFIGS, "sac_her_fetch_reach.yaml")
    out = her_vs_sb3.run_config(path, 7, 3000, str(tmp_path))
    with open(path) as f:
        before = yaml.safe_load(f)
    with open(out) as f:
        after = yaml.safe_load(f)
    assert after["params"]["seed"] == 7 and after["params"]["config"]["env_config"]["seed"] == 7
    assert after["params"]["config"]["max_frames"] == 3000 and "success_to_win" not in after["params"]["config"]
    for cfg in (before, after):
        cfg["params"].pop("seed")
        for key in ("env_config", "max_frames", "success_to_win"):
            cfg["params"]["config"].pop(key, None)
    assert before == after


def test_summarise_reports_success_at_fixed_frames_and_the_frames_to_the_target():
    runs = {"rlchain": [{"seed": 0, "events": FAST}], "sb3": [{"seed": 0, "events": SLOW}]}
    text = "\n".join(her_vs_sb3.summarise("reach", runs, 0.8, points=4))
    assert "| success at 450 frames | 0.50 +- 0.00 | 0.10 +- 0.00 | 5.00x |" in text
    assert "| frames to success 0.8 (seeds there: rlchain 1/1, sb3 1/1) | 600 +- 0 | 600 +- 0 | 1.00x |" in text
    assert "| frames/s (from process start) | 20.0 +- 0.0 | 10.0 +- 0.0 | 2.00x |" in text
    assert "| seconds to the first report (one epoch) | 10.0 +- 0.0 | 20.0 +- 0.0 | 0.50x |" in text


@pytest.mark.parametrize("reward_type", ["sparse", "dense"])
def test_the_sb3_side_computes_rlchains_fetch_reward(reward_type):
    rng = np.random.default_rng(0)
    achieved, desired = rng.normal(0, 0.05, (64, 3)), rng.normal(0, 0.05, (64, 3))
    theirs = sb3_her_driver.fetch_reward(achieved, desired, 0.05, reward_type)
    ours = fetch_compute_reward(achieved, desired, None, 0.05, reward_type)
    np.testing.assert_array_equal(theirs, ours)
    assert reward_type == "dense" or {0.0, -1.0} == set(theirs.tolist())


def test_sb3_hyperparameters_are_read_from_the_rlchain_yaml():
    pytest.importorskip("torch")
    push = sb3_her_driver.sb3_kwargs(sb3_her_driver.load_rlchain_yaml(os.path.join(CONFIGS, "sac_her_fetch_push.yaml")))
    assert push["task"] == "FetchPush-v4" and push["env_kwargs"] == {}
    assert (push["n_envs"], push["learning_rate"], push["batch_size"], push["buffer_size"]) == (4, 1e-3, 256, 1_000_000)
    assert (push["gamma"], push["tau"], push["learning_starts"], push["gradient_steps"]) == (0.98, 0.05, 2000, 2)
    assert (push["ent_coef"], push["net_arch"], push["n_sampled_goal"]) == ("auto_0.1", [256, 256], 4)
    assert (push["goal_selection_strategy"], push["window"], push["log_every"]) == ("future", 40, 200)
    assert push["normalize_input"] and push["target_entropy"] == "auto"


def test_sb3_side_refuses_what_sb3_cannot_match():
    params = sb3_her_driver.load_rlchain_yaml(os.path.join(CONFIGS, "sac_her_fetch_reach.yaml"))
    params["config"]["critic_lr"] = 3e-4
    with pytest.raises(SystemExit, match="one learning rate"):
        sb3_her_driver.sb3_kwargs(params)
    with pytest.raises(SystemExit, match="expected algo sac with replay.her"):
        sb3_her_driver.load_rlchain_yaml(os.path.join(CONFIGS, "sac_pendulum.yaml"))


# ----- tree_compare.py and epoch_cpu.py: this tree against another --------------------------------
def row(env, env_sps, rollout_sps, train_sps, num_envs=64):
    return {"env": env, "num_envs": num_envs, "env_sps": env_sps, "rollout_sps": rollout_sps, "train_sps": train_sps}


def test_medians_are_per_case_and_per_metric():
    runs = [[row("CartPole-v1", 10, 4, 1)], [row("CartPole-v1", 30, 2, 3)], [row("CartPole-v1", 20, 9, 2)]]
    assert tree_compare.medians(runs) == {("CartPole-v1", 64): {"env_sps": 20, "rollout_sps": 4, "train_sps": 2}}


def test_table_gives_each_version_and_the_ratio_head_over_base():
    old = {("HalfCheetah-v4", 64): {"env_sps": 100.0, "rollout_sps": 50.0, "train_sps": 40.0}}
    new = {("HalfCheetah-v4", 64): {"env_sps": 100.0, "rollout_sps": 55.0, "train_sps": 30.0},
           ("Ant-v4", 64): {"env_sps": 1.0, "rollout_sps": 1.0, "train_sps": 1.0}}  # not in base: left out
    lines = tree_compare.table("abc123", new, old).splitlines()
    assert "env_sps abc123" in lines[0] and "train_sps HEAD" in lines[0]
    assert len(lines) == 3 and lines[2].split()[0] == "HalfCheetah-v4"
    assert lines[2].split()[2:] == ["100", "100", "1.000", "50", "55", "1.100", "40", "30", "0.750"]


def test_a_revision_git_does_not_know_is_a_one_line_error():
    with pytest.raises(SystemExit) as exc:
        tree_compare.add_worktree("no-such-revision-xyz")
    message = str(exc.value)
    assert message.startswith("tree_compare.py: --base no-such-revision-xyz: no worktree") and "\n" not in message


@pytest.mark.smoke
def test_child_times_epochs_of_this_tree():
    row = epoch_cpu.child(ROOT, "torch:TorchCartPole-v0:64", ["params.config.mini_epochs=1"], warmup=0, epochs=1)
    assert row["tree"] == ROOT
    assert row["rollout_ms"] > 0 and row["update_ms"] > 0
    # 16 steps x 64 envs over the CPU seconds of both phases
    assert row["cpu_sps"] == pytest.approx(16 * 64 / ((row["rollout_ms"] + row["update_ms"]) / 1e3), rel=1e-6)


def test_a_base_tree_without_rlchain_is_a_one_line_error(tmp_path):
    with pytest.raises(SystemExit) as exc:
        epoch_cpu.main(["--base-tree", str(tmp_path), "--cases", "torch:TorchCartPole-v0:64"])
    message = str(exc.value)
    assert message.startswith(f"epoch_cpu.py: --base-tree {tmp_path}: no rlchain") and "\n" not in message


# ----- push_cube_eval.py -------------------------------------------------------------------------
def test_distance_inverts_the_reciprocal_tolerance_at_any_box_target_scale():
    d = np.array([0.0, 0.005, 0.03, 0.0796, 0.2])
    tol = np.where(d <= 0.005, 1.0, 1.0 / (1.0 + 9.0 * (d - 0.005) / 0.4))  # dm_control tolerance, 0.1 at the margin
    for scale in (8.0, 20.0):
        got = push_cube_eval.box_target_distance(scale * tol, scale)
        np.testing.assert_allclose(got, np.where(d <= 0.005, 0.0, d), atol=1e-12)
    # a term of 7.9 is 0.073 m when box_target_scale is 20, but 0.006 m if read with the default 8
    assert abs(push_cube_eval.box_target_distance(np.array([7.9]), 20.0)[0] - 0.073) < 1e-3


def test_off_policy_step_time_gives_median_quartiles_and_range_and_refuses_a_tree_without_rlchain(tmp_path):
    assert off_policy_step_time.spread([5.0, 1.0, 3.0, 2.0, 4.0]).split() == ["3.00", "[2.00-4.00]", "(1.00-5.00)"]
    with pytest.raises(SystemExit, match="--base-tree .*: no rlchain checkout there"):
        off_policy_step_time.main(["--base-tree", str(tmp_path)])
