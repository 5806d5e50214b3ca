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


def test_env_groups_values_and_layout_labels():
    from types import SimpleNamespace
    assert throughput.parse_groups("auto") == "auto" and throughput.parse_groups("2") == 2
    with pytest.raises(SystemExit, match="bad --env-groups value 'two'"):
        throughput.parse_groups("two")
    ppo = SimpleNamespace(pipeline_choice=SimpleNamespace(decided=True))
    two, one = SimpleNamespace(pools=[0, 1]), SimpleNamespace(pools=[0])
    assert throughput.layout_label(two, ppo, auto=True) == "a2p" and throughput.layout_label(one, ppo, True) == "a1"
    ppo.pipeline_choice.decided = False
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
    import rl_games_tensor_env

    env = rl_games_tensor_env.make_env("TorchCartPole-v0", 8, device="cpu", seed=3)
    assert env.num_envs == 8 and tuple(env.reset().shape) == (8, 4)


def test_rl_games_driver_scales_the_minibatch_with_num_actors_and_names_silu_as_rl_games_does(tmp_path):
    import rl_games_driver
    import yaml

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
    import rl_games_driver
    import yaml

    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump({"params": {"config": {"num_actors": 8}}}))
    unset = rl_games_driver.load_config(rl_games_driver.parse_args(["--file", str(path)]))["params"]
    assert "torch_threads" not in unset
    args = rl_games_driver.parse_args(["--file", str(path), "--torch-threads", "1"])
    assert rl_games_driver.load_config(args)["params"]["torch_threads"] == 1


def test_rl_games_driver_leaves_a_per_env_minibatch_to_scale_by_itself(tmp_path):
    import rl_games_driver
    import yaml

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
