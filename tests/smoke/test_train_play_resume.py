"""Shipped configs for a couple of epochs: train -> save -> play -> resume, via the CLI and the API."""

import glob
import os
import sys

import pytest
import torch

from rlchain import Runner
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS, ROOT
from tests.smoke.cli_server import run_python

pytestmark = pytest.mark.smoke


def run_cli(args, cwd, timeout=240):
    """``python runner.py ARGS`` in ``cwd``: its exit status and output (tests/smoke/cli_server.py runs it)."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return run_python([sys.executable, os.path.join(ROOT, "runner.py"), *args], cwd, env, timeout)


def small(tmp_path, epochs=2, extra=()):
    return [f"params.config.max_epochs={epochs}", f"params.config.train_dir={tmp_path}/runs",
            "params.config.save_best_after=0", "params.config.score_to_win=100000", *extra]


def test_cli_train_play_resume_cartpole(tmp_path):
    cfg = os.path.join(CONFIGS, "ppo_cartpole.yaml")
    out = run_cli(["--train", "--file", cfg, *small(tmp_path)], tmp_path)
    assert out.returncode == 0, out.stderr
    assert "epoch 2/2" in out.stdout and "frames 1024" in out.stdout
    runs = glob.glob(str(tmp_path / "runs" / "cartpole_*"))
    assert len(runs) == 1
    last = os.path.join(runs[0], "nn", "last_cartpole.pth")
    assert os.path.isfile(last)
    assert glob.glob(os.path.join(runs[0], "summaries", "events.out.tfevents.*"))

    play = run_cli(["--play", "--file", cfg, "--checkpoint", last, "--games", "2"], tmp_path)
    assert play.returncode == 0, play.stderr
    assert "av reward:" in play.stdout and "over 2 games" in play.stdout
    # the checkpoint carries its config: --play works without --file
    play2 = run_cli(["--play", "--checkpoint", last, "--games", "1"], tmp_path)
    assert play2.returncode == 0, play2.stderr

    resumed = run_cli(["--train", "--file", cfg, "--checkpoint", last, *small(tmp_path, epochs=4)], tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert "at epoch 2" in resumed.stdout
    assert "epoch 3/4" in resumed.stdout and "epoch 4/4" in resumed.stdout and "epoch 1/4" not in resumed.stdout


def test_resume_restores_state_exactly(tmp_path):
    runner = Runner().load(os.path.join(CONFIGS, "ppo_pendulum.yaml"), small(tmp_path, epochs=2))
    result = runner.train()
    path = os.path.join(result.run_dir, "nn", "last_pendulum.pth")
    saved = ckpt.load(path)
    assert saved["epoch"] == 2 and saved["frames"] == 2 * 16 * 64

    captured = {}

    def grab(ctx, stats, episodes):
        if "state" not in captured:
            captured["state"] = ctx.full_state()

    class Stop(Exception):
        pass

    runner2 = Runner().load(os.path.join(CONFIGS, "ppo_pendulum.yaml"), small(tmp_path, epochs=2))
    # with max_epochs 2 already reached, the resumed run restores then stops after one more check
    from rlchain.models.build import build_env, build_model, resolve_device
    params = runner2.params
    env = build_env(params, params.config.num_actors, 0)
    model = build_model(params, env, resolve_device("cpu"))
    from rlchain.algos.ppo.ppo import PPO
    from rlchain.runs.logging import TrainLogger
    from rlchain.training.loop import Loop
    trainer = Loop(params, PPO, env, model, torch.device("cpu"), None, TrainLogger(None, False), 0,
                   runner2.raw)
    trainer.restore(saved, path)
    env.close()
    state = trainer.checkpoints.state_dict()
    for key, value in saved["model"].items():
        assert torch.equal(state["model"][key], value), key
    assert state["agent"]["lr"] == saved["agent"]["lr"]
    assert state["epoch"] == 2 and state["frames"] == saved["frames"]
    assert state["best_reward"] == saved["best_reward"]
    assert torch.equal(state["rng"]["torch"], saved["rng"]["torch"])
    opt_saved = saved["agent"]["optimizer"]["state"]
    opt_now = state["agent"]["optimizer"]["state"]
    assert all(torch.equal(opt_saved[k]["exp_avg"], opt_now[k]["exp_avg"]) for k in opt_saved)
    assert model.running_mean_std is not None and torch.equal(state["model"]["running_mean_std.running_mean"],
                                                      saved["model"]["running_mean_std.running_mean"])


def test_same_seed_same_run(tmp_path):
    results = []
    for i in range(2):
        r = Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml"),
                          small(tmp_path / str(i), epochs=3, extra=["params.config.print_stats=false"]))
        r.train(seed=3)
        run = glob.glob(str(tmp_path / str(i) / "runs" / "cartpole_*"))[0]
        results.append(ckpt.load(os.path.join(run, "nn", "last_cartpole.pth"))["model"])
    for key in results[0]:
        assert torch.equal(results[0][key], results[1][key]), key


def test_user_network_via_import_modules(tmp_path):
    cfg = os.path.join(CONFIGS, "ppo_cartpole.yaml")
    out = run_cli(["--train", "--file", cfg, *small(tmp_path, epochs=1),
                   "params.import_modules=[tests.smoke.user_pkg]",
                   "params.network={name: testnet, hidden: 8}"], ROOT)
    assert out.returncode == 0, out.stderr
    assert "epoch 1/1" in out.stdout


@pytest.mark.parametrize("config", ["ppo_pendulum.yaml", "ppo_halfcheetah.yaml"])
def test_shipped_continuous_configs_run(tmp_path, config):
    if "halfcheetah" in config:
        pytest.importorskip("envpool")
    extra = ["params.config.num_actors=8", "params.config.minibatch_size=256"]
    result = Runner().load(os.path.join(CONFIGS, config), small(tmp_path, epochs=2, extra=extra)).train()
    assert result.epoch == 2
    run_dir = result.run_dir
    name = os.path.basename(config).replace("ppo_", "").replace(".yaml", "")
    play = Runner().load(os.path.join(CONFIGS, config)).play(
        os.path.join(run_dir, "nn", f"last_{name}.pth"), games=1, quiet=True)
    assert play.games == 1


def test_cli_export_onnx(tmp_path):
    pytest.importorskip("onnxruntime")
    out = run_cli(["--export", "onnx", "--checkpoint", os.path.join(ROOT, "nn", "cartpole.pth"),
                   "--output", str(tmp_path / "cartpole.onnx")], tmp_path)
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "cartpole.onnx").is_file() and "onnxruntime parity: max abs diff" in out.stdout
    missing = run_cli(["--export", "onnx", "--file", os.path.join(CONFIGS, "ppo_cartpole.yaml")], tmp_path)
    assert missing.returncode == 2 and "--export needs the checkpoint" in missing.stderr


def test_cli_track_offline(tmp_path):
    pytest.importorskip("wandb")
    env = dict(os.environ, WANDB_MODE="offline", WANDB_SILENT="true")
    cmd = [sys.executable, os.path.join(ROOT, "runner.py"), "--train", "--track", "--wandb-project-name", "p",
           "--file", os.path.join(CONFIGS, "ppo_cartpole.yaml"), *small(tmp_path, epochs=1)]
    out = run_python(cmd, tmp_path, env, 240)
    assert out.returncode == 0, out.stderr
    assert glob.glob(str(tmp_path / "runs" / "cartpole_*" / "wandb" / "offline-run-*" / "run-*.wandb"))


def test_train_py_with_json_config(tmp_path):
    import json

    import yaml
    with open(os.path.join(CONFIGS, "ppo_cartpole.yaml")) as fh:
        cfg = yaml.safe_load(fh)
    path = tmp_path / "train_config.json"
    path.write_text(json.dumps(cfg))
    env = dict(os.environ, PYTHONPATH=ROOT)
    out = run_python([sys.executable, os.path.join(ROOT, "train.py"), "--config", str(path),
                      *small(tmp_path, epochs=1)], tmp_path, env, 240)
    assert out.returncode == 0, out.stderr
    assert "epoch 1/1" in out.stdout


def test_resume_keeps_the_entropy_schedule(tmp_path):
    """schedule_entropy: a run stopped at epoch 2 of 4 and resumed trains with the same entropy coefficient
    and lr, epoch for epoch, as one that ran straight through."""
    import copy

    from rlchain.training.events import Callback
    from tests.conftest import BASE

    class Record(Callback):
        def __init__(self, stop_at=None):
            self.seen, self.stop_at, self.start = [], stop_at, None

        def on_train_start(self, ctx):
            self.start = ctx.algorithm.agent.entropy_coef

        def on_epoch_end(self, ctx, stats, episodes):
            agent = ctx.algorithm.agent
            self.seen.append((ctx.state.epoch, agent.entropy_coef, agent.lr, stats["entropy_coef"]))
            if ctx.state.epoch == self.stop_at:
                ctx.request_stop("test")

    def run(folder, record, checkpoint=None):
        cfg = copy.deepcopy(BASE)
        cfg["params"]["config"].update(lr_schedule="linear", schedule_entropy=True, entropy_coef=0.01,
                                       learning_rate=1e-3, max_epochs=4, train_dir=str(tmp_path / folder),
                                       print_stats=False)
        return Runner().load(cfg).train(checkpoint=checkpoint, callbacks=[record])

    straight = Record()
    run("straight", straight)
    assert [s[1] for s in straight.seen] == pytest.approx([1e-4 + 0.0099 * (1 - e / 4) for e in (1, 2, 3, 4)])
    assert all(s[1] == s[3] for s in straight.seen)  # the value logged as info/entropy_coef

    first, second = Record(stop_at=2), Record()
    result = run("stopped", first)
    assert result.epoch == 2
    run("resumed", second, checkpoint=os.path.join(result.run_dir, "nn", "last_t.pth"))
    assert second.start == straight.seen[1][1]  # restored, not entropy_coef from the config
    assert first.seen + second.seen == straight.seen
