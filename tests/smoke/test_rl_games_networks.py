"""Networks written the rl_games way (tests/smoke/rl_games_user_networks) train, resume, play and export:
through an rl_games script under ``python -m rlchain.rl_games`` and through ``runner.py``."""

import glob
import os
import sys

import pytest
import yaml

from rlchain import Runner
from tests.conftest import CONFIGS, ROOT
from tests.smoke.cli_server import run_python

pytestmark = pytest.mark.smoke

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore", "PYTHONPATH": ROOT}

SCRIPT = """
import glob, os, sys
import yaml
from rl_games.torch_runner import Runner
import tests.smoke.rl_games_user_networks  # registers the networks

cfg = yaml.safe_load(open(sys.argv[1]))
runner = Runner()
runner.load(cfg)
runner.run({"train": True})
train_dir = cfg["params"]["config"]["train_dir"]
last = sorted(glob.glob(os.path.join(train_dir, "*", "nn", "last_*.pth")), key=os.path.getmtime)[-1]
cfg["params"]["config"]["max_epochs"] = 3
runner = Runner()
runner.load(cfg)
runner.run({"train": True, "checkpoint": last})
runner = Runner()
runner.load(cfg)
played = runner.run({"play": True, "checkpoint": last})
print("PLAYED", played.games)
print("LAST", last)
"""

MLP = {"units": [32, 32], "activation": "tanh", "initializer": {"name": "default"}}
FORMS = {
    "recon_head": ("ppo_cartpole.yaml", {"name": "recon_head", "space": {"discrete": {}}, "mlp": MLP}),
    "small_base": ("ppo_pendulum.yaml", {"name": "small_base", "mlp": {**MLP, "activation": "elu"}}),
    "lambda_a2c": ("ppo_cartpole.yaml", {"name": "lambda_a2c", "space": {"discrete": {}}, "mlp": MLP,
                                         "rnn": {"name": "lstm", "units": 16, "layers": 1}}),
    "plain_module": ("ppo_cartpole.yaml", {"name": "plain_module"}),
    "rlg_sac": ("sac_pendulum.yaml", {"name": "rlg_sac", "separate": True, "mlp": {**MLP, "activation": "relu"},
                                      "log_std_bounds": [-5, 2]}),
}


def _config(tmp_path, form):
    base, network = FORMS[form]
    with open(os.path.join(CONFIGS, base)) as f:
        cfg = yaml.safe_load(f)
    cfg["params"]["network"] = network
    cfg["params"]["config"].update(max_epochs=2, train_dir=str(tmp_path / "runs"), score_to_win=100000,
                                   player={"games_num": 2, "deterministic": True})
    if form == "rlg_sac":
        cfg["params"]["config"].update(num_warmup_frames=100, num_steps_per_episode=50)
        return cfg
    cfg["params"]["config"].update(save_best_after=0, num_actors=8,
                                   minibatch_size=64 if form != "lambda_a2c" else 128)
    if form == "lambda_a2c":
        cfg["params"]["config"].update(seq_length=4, horizon_length=16)
    return cfg


@pytest.mark.parametrize("form", list(FORMS))
def test_rl_games_style_network_trains_resumes_plays_exports(tmp_path, form):
    cfg = _config(tmp_path, form)
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(cfg))
    script = tmp_path / "train.py"
    script.write_text(SCRIPT)
    out = run_python([sys.executable, "-m", "rlchain.rl_games", str(script), str(path)], tmp_path, ENV, 300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "at epoch 2" in out.stdout and "max_epochs 3 reached at epoch 3" in out.stdout, out.stdout[-2000:]
    assert "PLAYED 2" in out.stdout
    last = next(line[5:] for line in out.stdout.splitlines() if line.startswith("LAST "))
    pytest.importorskip("onnxruntime")
    import tests.smoke.rl_games_user_networks  # noqa: F401  (registers them in this process)

    onnx_path = Runner().load(cfg).export(last, str(tmp_path / "policy.onnx"))
    assert os.path.isfile(onnx_path)


def test_aux_loss_of_an_a2c_builder_subclass_is_logged_via_runner_py(tmp_path):
    _, network = FORMS["recon_head"]
    cfg = _config(tmp_path, "recon_head")
    cfg["params"]["import_modules"] = ["tests.smoke.rl_games_user_networks"]
    cfg["params"]["network"] = network
    path = tmp_path / "cfg.yaml"
    path.write_text(yaml.safe_dump(cfg))
    out = run_python([sys.executable, os.path.join(ROOT, "runner.py"), "--train", "--file", str(path)], tmp_path,
                     ENV, 300)
    assert out.returncode == 0, out.stderr[-3000:]
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(glob.glob(str(tmp_path / "runs" / "*" / "summaries"))[0])
    events.Reload()
    assert "losses/recon_loss" in events.Tags()["scalars"]
