"""rl_games' own example configs run as written (device set to cpu) for a couple of epochs."""

import os
import warnings

import pytest

from rlchain import Runner
from tests.conftest import ROOT

pytestmark = pytest.mark.smoke
RL_GAMES = os.path.join(ROOT, "benchmarks", "rl_games_configs")


@pytest.mark.parametrize("name", ["ppo_cartpole.yaml", "ppo_pendulum_torch.yaml", "halfcheetah_envpool.yaml",
                                  "ant_envpool.yaml", "ppo_cartpole_masked_velocity_rnn.yaml",
                                  "hopper_hop_envpool.yaml"])
def test_rl_games_config_runs_unchanged(tmp_path, name):
    if "envpool" in name:
        pytest.importorskip("envpool")
    overrides = ["params.config.max_epochs=2", f"params.config.train_dir={tmp_path}",
                 "params.config.print_stats=false"]
    if "envpool" in name:  # same config, fewer envs so the smoke tier stays quick
        overrides += ["params.config.num_actors=8", "params.config.horizon_length=32",
                      "params.config.minibatch_size=256"]
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        result = Runner().load(os.path.join(RL_GAMES, name), overrides).train()
    assert result.epoch == 2
    run_name = Runner().load(os.path.join(RL_GAMES, name)).params.config.name
    assert os.path.isfile(os.path.join(result.run_dir, "nn", f"last_{run_name}.pth"))


def test_rl_games_sac_halfcheetah_config_runs_unchanged(tmp_path):
    pytest.importorskip("envpool")
    overrides = [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
                 "params.config.max_frames=192", "params.config.num_warmup_frames=64",
                 "params.config.num_actors=4", "params.config.num_updates_per_step=2",
                 "params.config.replay_buffer_size=1000"]  # same config, a tiny budget for the smoke tier
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        result = Runner().load(os.path.join(RL_GAMES, "sac_halfcheetah_envpool.yaml"), overrides).train()
    assert result.frames == 192
    assert os.path.isfile(os.path.join(result.run_dir, "nn", "last_HalfCheetah-v4.pth"))
