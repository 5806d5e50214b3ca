"""Several short distributed runs in one torchrun launch, for tests/smoke/test_distributed.py.

``torchrun ... -m tests.smoke.dist_scenarios FOLDER NAME...``: each rank runs the named scenarios one after the
other, in this process: a training through the CLI's ``main`` (``grpo``: through train.py) or the collectives'
check (``collectives``). Each run joins the process group and leaves it at its end, as a launch of its own does.
Every scenario writes its ranks' final state (``DumpState``) to FOLDER/NAME/dumps and its runs to FOLDER/NAME/runs
(``collectives``: FOLDER/collectives/collectives{rank}.json), each rank's output to FOLDER/NAME/stdout{rank}.txt
and stderr{rank}.txt, its exit status to FOLDER/NAME/status{rank}.txt and the time it started (``time.time()``) to
FOLDER/NAME/started{rank}.txt. A launch costs its three processes about 15 s of CPU before any training (importing
torch, torch._dynamo and rlchain): one launch for all of them pays it once. A scenario that fails (the bad launches:
each rank's status is not 0) leaves the process group as a finished run does, so the next one starts clean;
``dead_rank`` ends the launch (torchrun stops rank 0 when rank 1 dies), so it comes last. The exit status is the
first failing scenario's.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time

CALLBACK = 'params.config.callbacks=["tests.smoke.test_distributed:DumpState"]'
DUMP_ENV = "RLCHAIN_TEST_DIST_DUMP"
SCORE = 60  # score's score_to_win


def _configs() -> str:
    from tests.conftest import CONFIGS

    return CONFIGS


def scenario_args(name: str, folder: str) -> list[str]:
    """runner.py's arguments for scenario ``name`` (its runs under ``folder``)."""
    from tests.conftest import ROOT

    configs = _configs()
    common = ["params.config.multi_gpu=True", f"params.config.train_dir={folder}/runs", CALLBACK]
    if name == "normalizers":  # normalize_input, normalize_value and the adaptive-KL schedule
        return ["--train", "--file", os.path.join(configs, "ppo_pendulum.yaml"), *common,
                "params.config.max_epochs=3"]
    if name == "appo":
        return ["--train", "--file", os.path.join(configs, "appo_pendulum.yaml"), *common,
                "params.config.max_epochs=3"]
    if name == "rnn":
        return ["--train", "--file", os.path.join(configs, "ppo_cartpole_masked_velocity_rnn.yaml"), *common,
                "params.config.max_epochs=2"]
    if name == "central_value":
        cv = ("{network: {name: actor_critic, central_value: True, mlp: {units: [32]}}, learning_rate: 1e-3, "
              "mini_epochs: 2}")
        return ["--train", "--file", os.path.join(configs, "ppo_cartpole.yaml"), *common,
                "params.config.max_epochs=3", "params.config.normalize_value=True",
                "params.import_modules=[tests.smoke.obs_state_cartpole]",
                "params.config.env_name=ObsStateCartPoleTest-v0",
                f"params.config.central_value_config={cv}"]
    if name == "aux_loss":
        return ["--train", "--file", os.path.join(ROOT, "benchmarks", "rl_games_configs",
                                                  "test_discrite_testnet_aux_loss.yaml"), *common,
                "params.config.max_epochs=2", "params.config.num_actors=4", "params.config.horizon_length=32",
                "params.config.minibatch_size=64"]
    if name == "distill":  # algo distill: an LSTM student of the packaged CartPole teacher (test_distill's FAST)
        from rlchain.config.packaged import resolve_checkpoint

        return ["--train", "--file", os.path.join(configs, "distill_cartpole_lstm.yaml"), *common,
                "params.config.num_actors=4", "params.config.horizon_length=16",
                "params.config.teacher_action_prob_epochs=1",
                f"params.config.teacher_checkpoint={resolve_checkpoint('cartpole')[0]}",
                "params.config.full_experiment_name=null", "params.config.max_epochs=3"]
    cartpole = os.path.join(configs, "ppo_cartpole.yaml")
    if name == "score":  # every rank stops at the same epoch on the reduced score
        return ["--train", "--file", cartpole, *common, f"params.config.score_to_win={SCORE}"]
    if name == "score_resume":  # score's last checkpoint, 2 epochs more, into score's runs folder
        last, epoch = last_checkpoint(os.path.join(os.path.dirname(folder), "score"), "last_cartpole.pth")
        return ["--train", "--file", cartpole, "--checkpoint", last, "params.config.multi_gpu=True",
                f"params.config.train_dir={os.path.dirname(folder)}/score/runs", CALLBACK,
                f"params.config.max_epochs={epoch + 2}", "params.config.score_to_win=100000"]
    small = ["params.network.mlp.units=[16]", "params.config.num_actors=4", "params.config.minibatch_size=32",
             "params.torch_threads=1", "params.update_threads=1", "params.config.score_to_win=100000",
             "params.config.save_frequency=3", "params.config.max_epochs=6"]
    if name == "straight":  # 6 epochs, a checkpoint every 3
        return ["--train", "--file", cartpole, *common, *small]
    if name == "resumed":  # straight's epoch-3 checkpoint resumed to 6
        last, _ = last_checkpoint(os.path.join(os.path.dirname(folder), "straight"), "cartpole_ep_3.pth")
        return ["--train", "--file", cartpole, *common, *small, "--checkpoint", last]
    # launches that must fail before a run folder (each rank's exit status is not 0)
    if name == "without_multi_gpu":
        return ["--train", "--file", cartpole, f"params.config.train_dir={folder}/runs"]
    if name == "different_configs":  # rank 1 parses one more override
        extra = ["params.config.num_actors=16"] if os.environ.get("RANK") == "1" else []
        return ["--train", "--file", cartpole, *common, *extra]
    if name == "different_checkpoints":  # rank 0 resumes score's last checkpoint, rank 1 starts fresh
        last, _ = last_checkpoint(os.path.join(os.path.dirname(folder), "score"), "last_cartpole.pth")
        return ["--train", "--file", cartpole, *common, *([] if os.environ.get("RANK") == "1" else
                                                          ["--checkpoint", last])]
    # a rank that dies (SIGKILL at epoch 3) ends the launch: the last scenario of one
    if name == "dead_rank":
        return ["--train", "--file", cartpole, "params.config.multi_gpu=True", f"params.config.train_dir={folder}/runs",
                "params.config.score_to_win=100000", "params.config.max_epochs=200",
                'params.config.callbacks=["tests.smoke.test_distributed:KillRank1"]']
    raise SystemExit(f"dist_scenarios: unknown scenario {name!r}")


def last_checkpoint(scenario: str, file: str) -> tuple[str, int]:
    """The path of ``file`` in the first run folder of a scenario that ran before, and its epoch."""
    import glob

    import torch

    path = sorted(glob.glob(os.path.join(scenario, "runs", "*", "nn", file)))[0]
    return path, int(torch.load(path, weights_only=False)["epoch"])


def grpo_config(folder: str) -> str:
    """An EmbodiChain-layout GRPO config (8 envs per rank, groups of 4: none straddles two ranks), for train.py."""
    import json

    actor = {"type": "mlp", "network_cfg": {"hidden_sizes": [16], "activation": "tanh"}}
    config = {"trainer": {"exp_name": "ec_grpo", "gym_config": "EmbodiChainCartPoleStandIn", "seed": 1,
                          "device": "cpu", "num_envs": 8, "iterations": 2, "buffer_size": 16, "save_freq": 0},
              "policy": {"name": "actor_only", "actor": actor},
              "algorithm": {"name": "grpo", "cfg": {"optimizer": {"name": "adam", "learning_rate": 1e-3},
                                                    "n_epochs": 2, "batch_size": 64, "group_size": 4,
                                                    "kl_coef": 0.01}}}
    path = os.path.join(folder, "train_config.json")
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(config, fh)
    return path


def run_train_py(argv: list[str]) -> int:
    """``python train.py ARGV`` in this process (its ``__main__`` block, as a launch runs it)."""
    import runpy

    from tests.conftest import ROOT

    previous = sys.argv
    sys.argv = [os.path.join(ROOT, "train.py"), *argv]
    try:
        runpy.run_path(sys.argv[0], run_name="__main__")
    except SystemExit as stop:
        return stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
    finally:
        sys.argv = previous
    return 0


def run_scenario(name: str, where: str) -> int:
    """Run one scenario on this rank; its exit status."""
    if name == "collectives":  # the syncs against hand-computed values, without a training run
        from tests.smoke.test_distributed import _collectives_worker

        _collectives_worker(where)
        return 0
    if name == "grpo":  # through train.py --distributed, with an EmbodiChain-layout config
        return run_train_py(["--config", grpo_config(where), "--distributed", f"params.config.train_dir={where}/runs",
                             CALLBACK, "params.torch_threads=1"])
    from rlchain.cli import main as cli_main

    return cli_main(scenario_args(name, where))


@contextlib.contextmanager
def captured(where: str, rank: str):
    """File descriptors 1 and 2 into ``where``/stdout{rank}.txt and stderr{rank}.txt (the test reads one
    scenario's output), then copied to the launch's own streams."""
    paths = [os.path.join(where, f"{stream}{rank}.txt") for stream in ("stdout", "stderr")]
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    for fd, path in zip((1, 2), paths):
        target = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(target, fd)
        os.close(target)
    try:
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        for fd, copy in zip((1, 2), saved):
            os.dup2(copy, fd)
            os.close(copy)
        for fd, path in zip((1, 2), paths):
            with open(path, "rb") as fh:
                os.write(fd, fh.read())


def main(folder: str, names: list[str]) -> int:
    rank = os.environ.get("RANK", "0")
    status = 0
    from torch.distributed import distributed_c10d

    for index, name in enumerate(names):
        # the process group's keys in torchrun's store are named after a counter that leaving the group resets:
        # a fresh range for each run, or one rank reads the other's address from the run before
        distributed_c10d._world.group_count = 1000 * (index + 1)
        where = os.path.join(folder, name)
        os.makedirs(os.path.join(where, "dumps"), exist_ok=True)
        os.environ[DUMP_ENV] = os.path.join(where, "dumps")
        with open(os.path.join(where, f"started{rank}.txt"), "w", encoding="utf-8") as fh:
            fh.write(repr(time.time()))
        with captured(where, rank):
            code = run_scenario(name, where)
        with open(os.path.join(where, f"status{rank}.txt"), "w", encoding="utf-8") as fh:
            fh.write(str(code))
        status = status or code
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2:]))
