"""Bad input through the CLI: one clear line on stderr, exit status 2, no traceback, no run folder
(a user network that breaks its contract at run time: one line, exit status 1)."""

import os

import pytest
import torch

from tests.conftest import CONFIGS, ROOT
from tests.smoke.test_train_play_resume import run_cli, small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")


def assert_one_line_error(out, *fragments):
    assert out.returncode == 2, out.stdout + out.stderr
    lines = [line for line in out.stderr.strip().splitlines() if "Warning" not in line and line.strip()]
    assert len(lines) == 1, out.stderr
    assert "Traceback" not in out.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def test_typo_in_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(open(CARTPOLE).read().replace("learning_rate:", "learnig_rate:"))
    out = run_cli(["--train", "--file", str(bad)], tmp_path)
    assert_one_line_error(out, "bad.yaml", "params.config.learnig_rate", "did you mean 'learning_rate'")
    assert not (tmp_path / "runs").exists()


def test_bad_override_value(tmp_path):
    out = run_cli(["--train", "--file", CARTPOLE, "params.config.mini_epochs=-1"], tmp_path)
    assert_one_line_error(out, "ppo_cartpole.yaml", "params.config.mini_epochs", "must be > 0")


def test_unknown_env(tmp_path):
    out = run_cli(["--train", "--file", CARTPOLE, "params.config.env_name=CartPole-v9"], tmp_path)
    assert_one_line_error(out, "ppo_cartpole.yaml", "params.config.env_name", "CartPole-v1")


def test_missing_checkpoint(tmp_path):
    out = run_cli(["--play", "--file", CARTPOLE, "--checkpoint", str(tmp_path / "nope.pth")], tmp_path)
    assert_one_line_error(out, "nope.pth", "not found")


def test_corrupt_checkpoint(tmp_path):
    bad = tmp_path / "bad.pth"
    bad.write_bytes(b"not a checkpoint at all")
    out = run_cli(["--play", "--file", CARTPOLE, "--checkpoint", str(bad)], tmp_path)
    assert_one_line_error(out, "bad.pth", "not a readable checkpoint")
    other = tmp_path / "other.pth"
    torch.save({"weights": 1}, other)
    out = run_cli(["--play", "--file", CARTPOLE, "--checkpoint", str(other)], tmp_path)
    assert_one_line_error(out, "other.pth", "not an rlchain checkpoint")


def test_mismatched_checkpoint(tmp_path):
    out = run_cli(["--train", "--file", CARTPOLE, *small(tmp_path, epochs=1)], tmp_path)
    assert out.returncode == 0, out.stderr
    last = next((tmp_path / "runs").glob("cartpole_*/nn/last_cartpole.pth"))
    out = run_cli(["--play", "--file", CARTPOLE, "--checkpoint", str(last), "params.network.mlp.units=[8, 8]"],
                  tmp_path)
    assert_one_line_error(out, "last_cartpole.pth", "shape")


def test_wrong_model_for_action_space(tmp_path):
    out = run_cli(["--train", "--file", CARTPOLE, "params.model.name=continuous_a2c_logstd"], tmp_path)
    assert_one_line_error(out, "ppo_cartpole.yaml", "use discrete_a2c")


def test_unimplemented_feature(tmp_path):
    out = run_cli(["--train", "--file", CARTPOLE, "params.config.freeze_critic=True"], tmp_path)
    assert_one_line_error(out, "params.config.freeze_critic", "not implemented")


def test_sigma_without_fixed_sigma(tmp_path):
    out = run_cli(["--play", "--file", CARTPOLE, "--checkpoint", os.path.join(ROOT, "nn", "cartpole.pth"),
                   "--sigma", "0.5"], tmp_path)
    assert_one_line_error(out, "--sigma", "fixed_sigma")


def test_non_scalar_aux_loss_names_the_key(tmp_path):
    out = run_cli(["--train", "--file", CARTPOLE, *small(tmp_path, epochs=1),
                   "params.import_modules=[tests.smoke.user_pkg]", "params.network={name: bad_aux_net}"], ROOT)
    assert out.returncode == 1, out.stdout + out.stderr
    lines = [line for line in out.stderr.strip().splitlines() if "Warning" not in line and line.strip()]
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    assert lines[0].startswith("network error: get_aux_loss()['value_l2'] must be a scalar tensor, got shape ("), \
        lines[0]


def test_resnet_previous_reward_without_a_dict_obs_env(tmp_path):
    """rl_games' ppo_pong_envpool_resnet.yaml without use_dict_obs_space: the network has no reward input."""
    pytest.importorskip("envpool")
    import yaml

    raw = yaml.safe_load(open(os.path.join(ROOT, "benchmarks", "rl_games_configs", "ppo_pong_envpool_resnet.yaml")))
    network = raw["params"]["network"]
    for block in ("cnn", "mlp"):
        network[block].pop("regularizer")  # its no-effect warnings would be extra lines
    del raw["params"]["config"]["env_config"]["use_dict_obs_space"]
    bad = tmp_path / "resnet.yaml"
    bad.write_text(yaml.safe_dump(raw))
    out = run_cli(["--train", "--file", str(bad), "params.config.num_actors=2", "params.config.minibatch_size=256",
                   *small(tmp_path)], tmp_path)
    assert_one_line_error(out, "resnet.yaml", "params.network.require_rewards: needs the previous reward",
                          "use_dict_obs_space: True")
    assert not (tmp_path / "runs").exists()
