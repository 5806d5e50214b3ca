"""The shipped PettingZoo configs train, play, resume and export (a couple of epochs each)."""

import os

import pytest

from rlchain import Runner
from rlchain.cli import main
from rlchain.runs import checkpoint as ckpt
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke
pytest.importorskip("pettingzoo")
pytest.importorskip("mpe2")

CASES = [("ppo_pz_simple_spread.yaml", "pz_simple_spread", {"shared"}),
         ("ppo_pz_simple_tag.yaml", "pz_simple_tag", {"predator", "prey"}),
         ("ppo_pz_connect_four_self_play.yaml", "pz_connect_four", {"learner", "opponent"})]


@pytest.mark.parametrize("config, name, policies", CASES)
def test_config_trains_plays_resumes_and_exports_every_policy(tmp_path, capsys, config, name, policies):
    path = os.path.join(CONFIGS, config)
    small = [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
             "params.config.max_epochs=2", "params.config.num_actors=2", "params.config.horizon_length=32",
             "params.config.minibatch_size=32"]
    result = Runner().load(path, small).train()
    last = os.path.join(result.run_dir, "nn", f"last_{name}.pth")
    state = ckpt.load(last)
    assert {key.split(".")[0] for key in state["model"]} == policies
    resumed = Runner().load(path, [*small, "params.config.max_epochs=3"]).train(checkpoint=last)
    assert resumed.epoch == 3
    played = Runner().load(path).play(last, games=2, quiet=True)
    assert played.games >= 2 and set(played.mean_rewards) == policies
    pytest.importorskip("onnxruntime")
    out = str(tmp_path / "policy.onnx")
    assert main(["--export", "onnx", "--file", path, "--checkpoint", last, "--output", out]) == 0
    for policy in policies:
        assert os.path.isfile(str(tmp_path / f"policy_{policy}.onnx"))
    one = sorted(policies)[0]
    assert main(["--export", "onnx", "--file", path, "--checkpoint", last, "--policy", one,
                 "--output", str(tmp_path / "one.onnx")]) == 0
    assert os.path.isfile(str(tmp_path / "one.onnx"))
    assert "onnxruntime parity" in capsys.readouterr().out


def test_export_of_an_unknown_policy_is_one_line(tmp_path, capsys):
    path = os.path.join(CONFIGS, "ppo_pz_simple_tag.yaml")
    result = Runner().load(path, [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
                                  "params.config.max_epochs=1", "params.config.num_actors=2",
                                  "params.config.minibatch_size=50"]).train()
    last = os.path.join(result.run_dir, "nn", "last_pz_simple_tag.pth")
    assert main(["--export", "onnx", "--file", path, "--checkpoint", last, "--policy", "wolf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].endswith("--policy: unknown policy 'wolf' (policies: predator, prey)"), err
