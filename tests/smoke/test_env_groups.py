"""Pipelined rollouts (``env_groups``): envpool env groups step in the background while the policy
acts for the other group. Same seed -> the same training as the synchronous rollout: the same env steps
and episodes, and the same parameters up to float rounding (the policy acts on a group of 8 envs instead
of 16, and on some CPUs a matrix product rounds differently for another batch size: ~1e-8 here on an
Intel Xeon, 0 on an AMD EPYC)."""

import os

import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.runs import checkpoint as ckpt
from rlchain.training.events import Callback

pytestmark = pytest.mark.smoke
pytest.importorskip("envpool")


def envpool_cartpole(tmp_path, groups, *extra):
    config = {"params": {
        "seed": 3, "algo": {"name": "a2c_discrete"}, "model": {"name": "discrete_a2c"},
        "network": {"name": "actor_critic", "space": {"discrete": None}, "mlp": {"units": [32]}},
        "config": {"name": "cp", "env_name": "envpool", "env_config": {"env_name": "CartPole-v1", "seed": 7},
                   "device": "cpu", "num_actors": 16, "horizon_length": 32, "minibatch_size": 128,
                   "mini_epochs": 2, "normalize_input": True, "normalize_value": True, "max_epochs": 4,
                   "print_stats": False, "save_best_after": 0, "train_dir": str(tmp_path / f"runs{groups}"),
                   "env_groups": groups}}}
    return Runner().load(config, list(extra))


def last_params(result):
    state = ckpt.load(os.path.join(result.run_dir, "nn", "last_cp.pth"))
    return state["model"]


def assert_same(a, b):
    assert a.keys() == b.keys()
    for key in a:
        assert torch.allclose(a[key], b[key], rtol=0, atol=1e-6), (key, (a[key] - b[key]).abs().max())


@pytest.mark.parametrize("extra", [(), ("params.network.rnn={name: lstm, units: 8}", "params.config.seq_length=8")],
                         ids=["mlp", "lstm"])
def test_two_groups_train_exactly_like_one(tmp_path, extra):
    one = envpool_cartpole(tmp_path, 1, *extra).train()
    two = envpool_cartpole(tmp_path, 2, *extra).train()
    assert one.epoch == two.epoch == 4 and one.frames == two.frames == 4 * 16 * 32
    assert one.mean_reward == two.mean_reward  # the same episodes, in the same envs
    assert_same(last_params(one), last_params(two))


def test_four_groups_and_auto(tmp_path):
    four = envpool_cartpole(tmp_path, 4).train()
    auto = envpool_cartpole(tmp_path, "auto").train()  # 16 envs -> 2 groups
    assert_same(last_params(four), last_params(auto))


def test_stop_request_mid_rollout_drains_groups_and_saves(tmp_path):
    class StopAfterRecvs(Callback):
        """Asks the trainer to stop after 5 group results, in the middle of the first rollout."""

        drives_trainer = True  # test instrument: wraps the training env's recv

        def on_train_start(self, trainer):
            env, recv, count = trainer.env, trainer.env.recv, [0]
            assert len(env.env_groups) == 2

            def counting(group):
                count[0] += 1
                if count[0] == 5:
                    trainer.request_stop("test")
                return recv(group)
            env.recv = counting

    result = envpool_cartpole(tmp_path, 2).train(callbacks=[StopAfterRecvs()])
    assert result.stop_reason == "stopped by request: test" and result.epoch == 0
    assert os.path.isfile(os.path.join(result.run_dir, "nn", "last_cp.pth"))


@pytest.mark.parametrize("groups,message", [
    (3, "params.config.env_groups: 3 does not divide num_actors 16"),
    (0, "params.config.env_groups"),
    ("two", "params.config.env_groups"),
])
def test_bad_env_groups_is_one_line(tmp_path, groups, message):
    with pytest.raises(ConfigError) as err:
        envpool_cartpole(tmp_path, groups).train()
    text = str(err.value)
    assert message in text and "\n" not in text


def test_env_groups_needs_envpool(tmp_path, base_config):
    base_config["params"]["config"].update(env_groups=2, max_epochs=1, train_dir=str(tmp_path))
    with pytest.raises(ConfigError, match=r"env_groups: 2 needs an envpool env"):
        Runner().load(base_config).train()
    base_config["params"]["config"]["env_groups"] = "auto"  # auto: synchronous for gymnasium envs
    assert Runner().load(base_config).train().epoch == 1
