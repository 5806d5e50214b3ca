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
    elif "rnn" in name:  # same config, a shorter horizon (minibatches of 32 LSTM sequences of seq_length 4)
        overrides += ["params.config.horizon_length=32", "params.config.minibatch_size=128"]
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
                 "params.config.replay_buffer_size=1000", "params.config.batch_size=32"]  # a tiny budget
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
        assert "a2c_network.linear1.weight" in ckpt.load(last)["central_value"]
    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    aux = [e.value for e in events.Scalars("losses/aux_dist_loss")] if "aux_loss" in name else []
    assert len(aux) == (2 if "aux_loss" in name else 0) and all(v >= 0 for v in aux)


RL_GAMES2 = os.path.join(ROOT, "benchmarks", "peers", "rl_games2_configs")


@pytest.mark.parametrize("name", ["hopper.yaml", "ant_envpool.yaml"])
def test_rl_games2_ppo_config_runs_unchanged(tmp_path, name):
    """rl_games 2.0's MuJoCo configs: the -v5 envs through gymnasium (async, as its use_async default) and
    envpool, mixed_precision True (bf16 autocast on CUDA, a no-op here)."""
    if "envpool" in name:
        pytest.importorskip("envpool")
    overrides = ["params.config.max_epochs=2", f"params.config.train_dir={tmp_path}", "params.config.device=cpu",
                 "params.config.print_stats=false",  # same config, fewer envs so the smoke tier stays quick
                 "params.config.num_actors=4", "params.config.horizon_length=32", "params.config.minibatch_size=64"]
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        result = Runner().load(os.path.join(RL_GAMES2, name), overrides).train()
    assert result.epoch == 2 and result.frames == 2 * 4 * 32
    run_name = Runner().load(os.path.join(RL_GAMES2, name)).params.config.name
    assert run_name.endswith(("-v5", "-v5_envpool"))
    assert os.path.isfile(os.path.join(result.run_dir, "nn", f"last_{run_name}.pth"))


def test_rl_games2_sac_config_runs_unchanged(tmp_path):
    """rl_games 2.0's SAC: utd_ratio (updates per env frame) and a layer-normed network."""
    pytest.importorskip("envpool")
    path = os.path.join(RL_GAMES2, "sac_ant_tuned.yaml")
    overrides = [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false", "params.config.device=cpu",
                 "params.config.max_frames=64", "params.config.num_warmup_frames=32", "params.config.num_actors=4",
                 "params.config.replay_buffer_size=1000", "params.config.batch_size=32"]  # a tiny budget
    runner = Runner().load(path, overrides)
    assert runner.params.config.num_updates_per_step == 4  # utd_ratio 1.0 * 4 actors
    assert runner.params.network.normalization == "layer_norm"
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        result = runner.train()
    assert result.frames == 64
    assert os.path.isfile(os.path.join(result.run_dir, "nn", "last_Ant-v5_SAC_envpool_tuned.pth"))
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    assert any(tag.startswith("losses/") for tag in events.Tags()["scalars"])  # it updated
