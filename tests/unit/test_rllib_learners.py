"""RLlib's num_learners through the face (rlchain/rllib/translate.py): more than one learner maps onto rlchain's
torch.distributed path (multi_gpu, one torchrun process per learner, each sampling its share of the batch); a
launch without torchrun ends in one line naming the command."""

import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib import translate
from rlchain.rllib.algorithms.dqn import DQNConfig
from rlchain.rllib.algorithms.ppo import PPOConfig


def _config(learners=2):
    return (PPOConfig().environment("CartPole-v1").env_runners(num_env_runners=1).learners(num_learners=learners)
            .training(train_batch_size=512, minibatch_size=64))


def test_several_learners_without_torchrun_name_the_command(monkeypatch):
    monkeypatch.delenv("WORLD_SIZE", raising=False)
    with pytest.raises(ConfigError, match=r"start the script with `torchrun --standalone --nproc_per_node=2 -m "
                                          r"rlchain\.rllib ") as info:
        _config().validate()
    assert "\n" not in str(info.value)
    monkeypatch.setenv("WORLD_SIZE", "3")
    with pytest.raises(ConfigError, match=r"nproc_per_node=2 .*this launch has WORLD_SIZE=3"):
        _config().validate()


def test_under_torchrun_each_learner_samples_its_share_on_the_multi_gpu_path(monkeypatch):
    monkeypatch.setenv("WORLD_SIZE", "2")
    cfg = translate.ppo_config(_config(), "CartPole-v1", False, {})["params"]["config"]
    assert cfg["multi_gpu"] and cfg["num_actors"] * cfg["horizon_length"] == 256
    assert cfg["minibatch_size"] == 64  # RLlib's minibatch_size is per learner
    single = translate.ppo_config(_config(0), "CartPole-v1", False, {})["params"]["config"]
    assert not single["multi_gpu"] and single["horizon_length"] == 512
    with pytest.raises(ConfigError, match="several learners train PPO only"):
        DQNConfig().learners(num_learners=2).validate()
