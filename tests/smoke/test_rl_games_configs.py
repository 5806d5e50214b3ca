"""rl_games' own example configs run as written (device set to cpu) for a couple of epochs."""

import os
import warnings

import pytest

from rlchain import Runner
from rlchain.runs import checkpoint as ckpt
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


@pytest.mark.parametrize("name", ["test_discrite_testnet_aux_loss.yaml", "test_asymmetric_discrete_mhv_mops.yaml"])
def test_rl_games_test_network_configs_run_unchanged(tmp_path, name):
    """rl_games' test networks (testnet as actor and critic, testnet_aux_loss with its auxiliary
    loss logged as losses/aux_dist_loss) on TestRnnEnv-v0's Dict observations."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    overrides = ["params.config.max_epochs=2", f"params.config.train_dir={tmp_path}",
                 "params.config.print_stats=false", "params.config.num_actors=4",  # same config, fewer envs
                 "params.config.horizon_length=64", "params.config.minibatch_size=128",
                 "params.config.central_value_config.minibatch_size=128"]
    if "aux_loss" in name:
        overrides = overrides[:-1]  # no central value there
    result = Runner().load(os.path.join(RL_GAMES, name), overrides).train()
    assert result.epoch == 2
    last = os.path.join(result.run_dir, "nn", "last_test_md_multi_obs.pth")
    if "mhv_mops" in name:  # the critic is central_value_config.network's testnet, not an MLP
        assert "network.net.linear1.weight" in ckpt.load(last)["central_value"]
    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    aux = [e.value for e in events.Scalars("losses/aux_dist_loss")] if "aux_loss" in name else []
    assert len(aux) == (2 if "aux_loss" in name else 0) and all(v >= 0 for v in aux)
