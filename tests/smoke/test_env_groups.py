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
from tests.conftest import installed

pytestmark = [pytest.mark.smoke, installed("envpool")]


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

        def on_train_start(self, ctx):
            env, recv, count = ctx.training_env, ctx.training_env.recv, [0]
            assert len(env.env_groups) == 2

            def counting(group):
                count[0] += 1
                if count[0] == 5:
                    ctx.request_stop("test")
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



@pytest.mark.parametrize("layout", ["one pool", "two pools"])
def test_auto_trains_like_one_group_whichever_layout_wins(tmp_path, monkeypatch, layout):
    """env_groups: auto measures one pool against two (and then, with two, the pipelined rollout against the
    rollout stepped together, switching ways over epochs 1-6): whatever it picks, the same training."""
    from rlchain.algos.ppo import env_layout
    picked = env_layout.ONE_POOL if layout == "one pool" else env_layout.TWO_POOLS
    monkeypatch.setattr(env_layout, "fastest", lambda seconds: picked)
    built = []
    choose = env_layout.choose_env_layout

    def recording(params, env, seed):
        env = choose(params, env, seed)
        built.append(len(env.pools))
        return env
    monkeypatch.setattr("rlchain.algos.ppo.ppo.choose_env_layout", recording)
    one = envpool_cartpole(tmp_path, 1, "params.config.max_epochs=8").train()
    auto = envpool_cartpole(tmp_path, "auto", "params.config.max_epochs=8").train()
    assert built == [picked.pools]
    assert one.mean_reward == auto.mean_reward and one.frames == auto.frames
    assert_same(last_params(one), last_params(auto))


def test_layout_probe_leaves_the_random_state_and_the_seeds_alone(tmp_path):
    """The probe steps the envs with a throwaway policy: the torch random state is as before, and the first
    seeded reset restarts every env from the run's seed."""
    from rlchain.algos.ppo.ppo import PPO
    from rlchain.envs.backends.envpool_env import EnvpoolVecEnv
    params = envpool_cartpole(tmp_path, "auto").params
    torch.manual_seed(11)
    before = torch.get_rng_state()
    env = PPO.build_training_env(params, 7)
    reference = EnvpoolVecEnv("CartPole-v1", 16, seed=7)
    try:
        assert torch.equal(before, torch.get_rng_state())
        assert (env.reset(seed=7) == reference.reset(seed=7)).all()
    finally:
        env.close()
        reference.close()
