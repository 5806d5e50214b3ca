"""EmbodiChain's train_config layout -> rlchain's typed config (rlchain/config/embodichain.py).

The configs here are this project's own, in EmbodiChain's layout (not copies of its files)."""

import json

import pytest
import yaml

import rlchain.builtins  # noqa: F401
from rlchain.builtins import register_builtins
from rlchain.config.embodichain import is_embodichain, translate
from rlchain.config.errors import ConfigError
from rlchain.config.load import load_config

register_builtins()


def layout(algo="ppo", **trainer):
    """A small config in EmbodiChain's current layout."""
    base = {"exp_name": "demo", "gym_config": "EmbodiChainPushStandIn", "seed": 3, "device": "cpu",
            "num_envs": 8, "iterations": 5, "buffer_size": 16, "enable_eval": True, "eval_freq": 200,
            "save_freq": 300, "num_eval_envs": 2, "num_eval_episodes": 4}
    base.update(trainer)
    actor = {"type": "mlp", "network_cfg": {"hidden_sizes": [32, 32], "activation": "relu"}}
    policy = {"name": "actor_critic", "actor": actor, "critic": actor} if algo == "ppo" else \
        {"name": "actor_only", "actor": actor}
    cfg = {"optimizer": {"name": "adam", "learning_rate": 1e-3}, "n_epochs": 2, "batch_size": 64,
           "gamma": 0.98, "clip_coef": 0.25, "ent_coef": 0.0, "max_grad_norm": 0.7}
    if algo == "ppo":
        cfg.update(gae_lambda=0.9, vf_coef=0.5)
    if algo == "grpo":
        cfg.update(kl_coef=0.01, group_size=4, eps=1e-8, reset_every_rollout=True, truncate_at_first_done=True)
    return {"trainer": base, "policy": policy, "algorithm": {"name": algo, "cfg": cfg}}


def write(tmp_path, data, name="train_config.json"):
    path = tmp_path / name
    plain = json.loads(json.dumps(data))  # no shared objects: YAML would write them as aliases
    path.write_text(json.dumps(plain) if name.endswith(".json") else yaml.safe_dump(plain))
    return str(path)


def test_ppo_keys_keep_embodichain_meaning(tmp_path):
    cfg = load_config(write(tmp_path, layout())).config
    assert (cfg.num_actors, cfg.horizon_length, cfg.max_epochs) == (8, 16, 5)
    assert (cfg.mini_epochs, cfg.minibatch_size, cfg.gamma, cfg.tau, cfg.e_clip) == (2, 64, 0.98, 0.9, 0.25)
    assert cfg.learning_rate == 1e-3 and cfg.lr_schedule is None
    assert cfg.critic_coef == 1.0  # vf_coef * MSE == 0.5 * critic_coef * MSE
    assert not cfg.clip_value and not cfg.normalize_input and not cfg.normalize_value and not cfg.value_bootstrap
    assert cfg.normalize_advantage and not cfg.clip_actions and cfg.grad_norm == 0.7 and cfg.truncate_grads
    # 200 env steps with 8 envs x 16 steps = 128 per epoch: every 2nd epoch; saves stay in env steps
    assert cfg.evaluation.interval == 2 and cfg.save_best_after == 0
    assert (cfg.save_frequency, cfg.save_frequency_frames, cfg.checkpoint_names) == (0, 300, "embodichain")
    assert (cfg.evaluation.games, cfg.evaluation.num_envs, cfg.evaluation.seed) == (4, 2, 10_003)


def test_yaml_and_json_read_the_same(tmp_path):
    a = load_config(write(tmp_path, layout(), "a.json")).config
    b = load_config(write(tmp_path, layout(), "b.yaml")).config
    assert a == b


def test_old_layout_rollout_steps_and_flat_learning_rate(tmp_path):
    data = layout()
    data["trainer"]["rollout_steps"] = data["trainer"].pop("buffer_size")
    data["trainer"]["enable_rt"] = False  # the old layout's DexSim ray-tracing switch
    data["algorithm"]["cfg"]["learning_rate"] = data["algorithm"]["cfg"].pop("optimizer")["learning_rate"]
    with pytest.warns(UserWarning, match="old"):
        cfg = load_config(write(tmp_path, data)).config
    assert cfg.horizon_length == 16 and cfg.learning_rate == 1e-3
    data["trainer"]["buffer_size"] = 32
    with pytest.raises(ConfigError, match=r"trainer.rollout_steps: both trainer.rollout_steps \(old layout\) and "
                                          r"trainer.buffer_size given; keep trainer.buffer_size"):
        load_config(write(tmp_path, data))
    data["trainer"].pop("rollout_steps")
    data["algorithm"]["cfg"]["optimizer"] = {"learning_rate": 1e-4}
    with pytest.raises(ConfigError, match=r"algorithm.cfg.learning_rate: both .* keep algorithm.cfg.optimizer"):
        load_config(write(tmp_path, data))


def test_network_and_policy(tmp_path):
    data = layout()
    data["policy"]["initial_log_std"] = -1.0
    params = load_config(write(tmp_path, data))
    net = params.network
    assert net.separate and net.mlp.units == [32, 32] and net.mlp.activation == "relu"
    assert net.space.continuous.fixed_sigma and net.space.continuous.sigma_init.val == -1.0
    assert params.algo.name == "a2c_continuous" and params.model.name == "continuous_a2c_logstd"


@pytest.mark.parametrize("where, key, hint", [
    ("trainer", "num_env", "num_envs"),
    ("cfg", "clip_coeff", "clip_coef"),
    ("top", "trainr", "trainer"),
])
def test_unknown_key_is_an_error_with_did_you_mean(tmp_path, where, key, hint):
    data = layout()
    target = {"trainer": data["trainer"], "cfg": data["algorithm"]["cfg"], "top": data}[where]
    target[key] = 1
    with pytest.raises(ConfigError, match=f"did you mean '{hint}'"):
        load_config(write(tmp_path, data))


def test_dexsim_task_not_installed_is_a_clear_error(tmp_path):
    (tmp_path / "gym_config.json").write_text(json.dumps({"id": "PushCubeRL", "max_episode_steps": 100}))
    data = layout(gym_config="gym_config.json")
    with pytest.raises(ConfigError, match="task 'PushCubeRL'.*DexSim"):
        load_config(write(tmp_path, data))


def test_gym_config_file_names_a_registered_env(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "gym_config.json").write_text(json.dumps({"id": "EmbodiChainCartPoleStandIn"}))
    # the path is relative to the config's repository root (a folder above it), as EmbodiChain writes them
    data = layout(gym_config="sub/gym_config.json")
    (tmp_path / "sub" / "deep").mkdir()
    assert load_config(write(tmp_path / "sub" / "deep", data)).config.env_name == "EmbodiChainCartPoleStandIn"


def test_learning_env_with_cfg(tmp_path):
    data = layout()
    data["trainer"].pop("gym_config")
    data["trainer"]["learning_env"] = {"name": "TorchPointMass-v0", "cfg": {"max_episode_steps": 50}}
    cfg = load_config(write(tmp_path, data)).config
    assert cfg.env_name == "TorchPointMass-v0" and cfg.env_config == {"max_episode_steps": 50, "device": "cpu"}


def test_overrides_on_embodichain_keys_and_params(tmp_path):
    path = write(tmp_path, layout())
    params = load_config(path, ["trainer.num_envs=4", "params.config.print_stats=false"])
    assert params.config.num_actors == 4 and params.config.print_stats is False


def test_distributed_is_multi_gpu_and_events_map(tmp_path):
    data = layout(distributed=True, events={
        "eval": {"cam": {"func": "record_camera_data_async", "mode": "interval", "interval_step": 1,
                         "params": {"save_path": "videos"}}},
        "train": {"tick": {"func": "mypkg.events.tick", "interval_step": 5, "params": {"x": 1}}}})
    raw = translate(data, "t.json")["params"]["config"]
    assert raw["multi_gpu"] is True
    assert raw["events"] == [{"func": "video", "phase": "eval", "interval_step": 1, "params": {"save_path": "videos"}},
                             {"func": "mypkg.events:tick", "phase": "train", "interval_step": 5, "params": {"x": 1}}]


def test_other_optimizers_are_errors(tmp_path):
    data = layout()
    data["algorithm"]["cfg"]["optimizer"]["name"] = "sgd"
    with pytest.raises(ConfigError, match="optimizer.name"):
        load_config(write(tmp_path, data))


def test_a_critic_unlike_the_actor_is_built_as_its_own_network(tmp_path):
    import gymnasium as gym
    import torch

    from rlchain.networks.actor_critic import ActorCriticBuilder

    data = layout()
    data["policy"]["actor"]["network_cfg"].update(dropout_p=0.1)
    data["policy"]["critic"] = {"type": "mlp", "network_cfg": {
        "hidden_sizes": [64, 48, 8], "activation": "tanh", "use_layernorm": True, "last_activation": "relu",
        "orthogonal_init": [1.0, 1.0, 1.0, 0.5]}}
    net = load_config(write(tmp_path, data)).network
    assert net.separate and net.mlp.units == [32, 32] and net.mlp.dropout == 0.1
    critic = net.critic_mlp
    assert (critic.units, critic.activation, critic.normalization, critic.dropout) == ([64, 48, 8], "tanh",
                                                                                       "layer_norm", 0.0)
    assert critic.initializer.gain == 1.0 and net.value_activation == "relu"
    builder = ActorCriticBuilder()
    builder.load(net)
    model = builder.build("x", input_shape=(5,), actions_num=2, action_space=gym.spaces.Box(-1, 1, (2,)))
    assert model.value.in_features == 8 and model.mu.in_features == 32
    assert any(isinstance(m, torch.nn.Dropout) for m in model.actor_mlp.modules())
    assert any(isinstance(m, torch.nn.LayerNorm) for m in model.critic_mlp.modules())
    mu, _, value, _ = model({"obs": torch.zeros(3, 5)})
    assert mu.shape == (3, 2) and value.shape == (3, 1) and (value >= 0).all()
    same = load_config(write(tmp_path, layout())).network  # the actor's sizes: no critic block of its own
    assert same.separate and same.critic_mlp is None


def test_critic_mlp_needs_separate():
    from rlchain.config.network_block import parse_network

    block = {"name": "actor_critic", "separate": False, "critic_mlp": {"units": [8]}, "mlp": {"units": [8]}}
    with pytest.raises(ConfigError, match=r"cfg.yaml: params.network.critic_mlp: a critic of its own needs "
                                          r"separate: True"):
        parse_network(block, "cfg.yaml")


def test_best_eval_metric_success_rate(tmp_path):
    data = layout(best_eval_metric="eval/success_rate", best_eval_mode="max")
    assert load_config(write(tmp_path, data)).config.evaluation.select_best == "evaluation_success"
    evaluation = load_config(write(tmp_path, layout(best_eval_metric="eval/avg_length", best_eval_mode="min"))
                             ).config.evaluation
    assert (evaluation.select_best, evaluation.best_mode) == ("evaluation_length", "min")


def test_best_mode_min_keeps_the_lowest_score():
    from types import SimpleNamespace

    from rlchain.training.evaluation import _score, is_better

    result = SimpleNamespace(mean_reward=1.0, mean_length=30.0, success_rate=0.5)
    assert _score("evaluation_length", result) == 30.0 and _score("evaluation_success", result) == (0.5, 1.0)
    assert is_better(30.0, None, "min") and is_better(20.0, 30.0, "min") and not is_better(40.0, 30.0, "min")
    assert is_better(40.0, 30.0) and not is_better(30.0, 30.0) and not is_better(None, None)


def test_linear_lr_scheduler_end_factor(tmp_path):
    data = layout()
    data["algorithm"]["cfg"]["lr_scheduler"] = {"name": "linear", "kwargs": {"end_factor": 0.4}}
    cfg = load_config(write(tmp_path, data)).config
    assert cfg.lr_schedule == "linear" and cfg.min_lr == pytest.approx(4e-4)


def test_is_embodichain():
    assert is_embodichain(layout()) and not is_embodichain({"params": {}})


def test_a_critic_of_its_own_has_no_rl_games_export():
    import torch

    from rlchain.runs.rl_games_checkpoint import to_rl_games

    model = {"a2c_network.actor_mlp.0.weight": torch.zeros(32, 5),
             "a2c_network.critic_mlp.0.weight": torch.zeros(64, 5)}
    with pytest.raises(ValueError, match="critic_mlp"):
        to_rl_games({"model": model})
