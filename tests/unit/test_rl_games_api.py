"""rlchain.rl_games: rl_games' Python API names on rlchain (registries, observers, the Runner's config
handling, the player, the import alias). Fast: no training here (tests/smoke/test_rl_games_scripts.py trains)."""

import importlib
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain.config import ConfigError
from rlchain.registry import ENVS, VECENVS
from rlchain.rl_games import alias
from rlchain.rl_games.__main__ import main as launcher_main
from rlchain.rl_games.algos_torch import model_builder
from rlchain.rl_games.algos_torch.players import PpoPlayerDiscrete
from rlchain.rl_games.algos_torch.torch_ext import AverageMeter
from rlchain.rl_games.common import env_configurations, vecenv
from rlchain.rl_games.common.algo_observer import DefaultAlgoObserver, IsaacAlgoObserver
from rlchain.rl_games.torch_runner import Runner


@pytest.fixture
def registries(scoped_registries):
    """Registrations made by a test vanish after it, gym's too."""
    yield
    for name in ("api_test_env",):
        gym.registry.pop(name, None)


def test_vecenv_and_env_configurations_fill_rlchains_registries(registries):
    def creator(config_name, num_actors, **kwargs):
        return ("made", config_name, num_actors, kwargs)

    vecenv.register("ApiTestWrapper", creator)
    vecenv.register("ApiTestWrapper", creator)  # registering again replaces, as in rl_games
    assert VECENVS.get("ApiTestWrapper") is creator
    env_configurations.register("api_test_env", {"vecenv_type": "ApiTestWrapper", "env_creator": lambda **kw: None})
    env_configurations.register("api_test_env", {"vecenv_type": "ApiTestWrapper", "env_creator": lambda **kw: None})
    assert env_configurations.configurations is ENVS  # one table, rlchain's own envs in it too
    assert ENVS["api_test_env"]["vecenv_type"] == "ApiTestWrapper" and "openai_gym" in ENVS
    assert vecenv.create_vec_env("api_test_env", 8, a=1) == ("made", "api_test_env", 8, {"a": 1})
    with pytest.raises(ValueError, match="'nope' has no env_configurations entry"):
        vecenv.create_vec_env("nope", 8)


def test_ivecenv_defaults():
    env = vecenv.IVecEnv()
    assert env.get_number_of_agents() == 1 and env.has_action_masks() is False
    assert env.get_env_state() is None
    env.set_train_info(100)
    with pytest.raises(NotImplementedError):
        env.step(None)


def test_average_meter_keeps_the_mean_of_the_last_max_size_values():
    meter = AverageMeter(1, 4)
    meter.update(torch.tensor([[1.0], [3.0]]))
    assert meter.current_size == 2 and float(meter.get_mean()) == pytest.approx(2.0)
    meter.update(torch.tensor([[5.0], [7.0], [9.0]]))  # 3 new values: one old one is kept
    assert meter.current_size == 4 and float(meter.get_mean()) == pytest.approx((2.0 + 3 * 7.0) / 4)
    meter.clear()
    assert meter.current_size == 0


class FakeWriter:
    def __init__(self):
        self.scalars = []

    def add_scalar(self, tag, value, step):
        self.scalars.append((tag, float(value), step))


class FakeAlgo:
    def __init__(self):
        self.writer, self.games_to_track, self.num_agents = FakeWriter(), 10, 1
        self.ppo_device = self.device = "cpu"


def test_isaac_observer_writes_episode_and_log_statistics_and_direct_scalars():
    algo = FakeAlgo()
    obs = IsaacAlgoObserver()
    obs.after_init(algo)
    obs.process_infos({"episode": {"reward": torch.tensor(2.0)}, "time_outs": torch.zeros(4, dtype=torch.bool),
                       "curriculum": 0.5}, torch.zeros(0, 1, dtype=torch.long))
    obs.process_infos({"log": {"reward": torch.tensor([4.0, 6.0])}}, torch.zeros(0, 1, dtype=torch.long))
    obs.after_print_stats(1000, 3, 12.0)
    tags = {(t, s): v for t, v, s in algo.writer.scalars}
    assert tags[("Episode/reward", 3)] == pytest.approx(4.0)  # mean of 2, 4, 6
    assert tags[("curriculum/frame", 1000)] == 0.5 and ("time_outs/frame", 1000) not in tags
    with pytest.raises(ValueError, match="expects the env's infos as a dict"):
        obs.process_infos([{}], torch.zeros(0, 1, dtype=torch.long))


def test_default_observer_averages_scores_of_finished_games():
    algo = FakeAlgo()
    obs = DefaultAlgoObserver()
    obs.after_init(algo)
    obs.process_infos({"scores": np.array([1.0, 2.0, 3.0])}, torch.tensor([[0], [2]]))
    obs.process_infos([{"scores": 10.0}, {}], torch.tensor([[0], [1]]))
    obs.after_print_stats(500, 2, 1.0)
    assert ("scores/mean", pytest.approx((1 + 3 + 10) / 3), 500) in algo.writer.scalars


def test_runner_load_sets_script_keys_aside_and_names_bad_keys(base_config):
    base_config["params"]["env"] = {"clip_observations": 5.0}  # Isaac Lab's: read by its train.py
    base_config["params"]["load_checkpoint"] = True
    base_config["params"]["load_path"] = "some/run/nn/x.pth"
    runner = Runner()
    runner.load(base_config)  # load_checkpoint / load_path: the checkpoint run() resumes without one
    assert runner.script_params == {"env": {"clip_observations": 5.0}}
    assert runner.load_path == "some/run/nn/x.pth" and runner.algo_name == "a2c_discrete" and runner.seed == 1
    base_config["params"]["config"]["horizon_lenght"] = 8
    with pytest.raises(ConfigError, match=r"params\.config\.horizon_lenght.*horizon_length"):
        Runner().load(base_config)
    with pytest.raises(ValueError, match="a dict with a 'params' dict"):
        Runner().load({"config": {}})


def test_player_acts_on_one_or_a_batch_of_observations(base_config):
    runner = Runner()
    runner.load(base_config)
    player = runner.create_player()
    assert isinstance(player, PpoPlayerDiscrete) and player.obs_shape == (4,) and not player.is_rnn
    one = player.get_action(np.zeros(4, np.float32), is_deterministic=True)
    assert one.shape == () and int(one) in (0, 1)
    batch = np.zeros((5, 4), np.float32)
    assert player.get_batch_size(batch, 1) == 5 and player.has_batch_dimension
    assert player.get_action(player.obs_to_torch({"obs": batch}), True).shape == (5,)
    same = player.get_action(batch, is_deterministic=True)
    assert torch.equal(same, player.get_action(batch, is_deterministic=True))  # the mode: no sampling


def test_register_model_takes_rl_games_model_classes_and_rejects_other_objects(registries):
    from rlchain.registry import MODELS
    from rlchain.rl_games.algos_torch import models

    class MyModel(models.ModelA2CContinuousLogStd):  # rl_games' form: built later with .build(config)
        pass

    model_builder.register_model("rlg_style", lambda network, **kwargs: MyModel(network))
    assert models.rlchain_preset(MyModel) == "continuous_a2c_logstd"

    class NotAModel:
        def __init__(self, network):
            self.network = network

    model_builder.register_model("not_a_model", NotAModel)
    with pytest.raises(ValueError, match="'not_a_model' returned a NotAModel, neither a subclass"):
        MODELS.get("not_a_model")(network=None)


def test_alias_resolves_rl_games_names_to_rlchain_and_uninstalls():
    assert "rl_games" not in sys.modules or not sys.modules["rl_games"].__name__.startswith("rlchain")
    saved = {n: m for n, m in sys.modules.items() if n == "rl_games" or n.startswith("rl_games.")}
    try:
        alias.install()
        runner_mod = importlib.import_module("rl_games.torch_runner")
        from rl_games.common import vecenv as aliased_vecenv  # noqa: PLC0415 - the alias is the subject

        assert runner_mod.Runner is Runner and aliased_vecenv is vecenv
        assert runner_mod.__spec__.name == "rlchain.rl_games.torch_runner"  # the module keeps its own spec
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module("rl_games.common.no_such_module")
    finally:
        alias.uninstall()
        sys.modules.update(saved)
    assert not any(isinstance(f, alias.RlGamesAlias) for f in sys.meta_path)
    assert alias.target_name("rl_games.common") == "rlchain.rl_games.common"
    assert alias.target_name("rl_gamesx") is None and alias.target_name("numpy") is None


def test_launcher_bad_launch_lines_are_one_line_errors(tmp_path, capsys):
    assert launcher_main([str(tmp_path / "missing.py")]) == 2
    err = capsys.readouterr().err.strip()
    assert "missing.py: no such script file" in err and len(err.splitlines()) == 1
    assert launcher_main([]) == 2 and "usage: python -m rlchain.rl_games SCRIPT" in capsys.readouterr().err
    assert launcher_main(["--help"]) == 0 and "usage:" in capsys.readouterr().out


def test_config_algo_observer_unless_one_is_given(base_config):
    base_config["params"]["config"]["algo_observer"] = "isaac"
    runner = Runner()
    runner.load(base_config)
    assert isinstance(runner.algo_observer, IsaacAlgoObserver)  # built from the config, as rl_games 2.0 does
    assert runner._runner.params.config.callbacks == []  # called as the Runner's observer, not twice
    given = DefaultAlgoObserver()
    runner = Runner(given)
    runner.load(base_config)  # an observer passed to Runner wins, as in rl_games 2.0
    assert runner.algo_observer is given and runner._runner.params.config.callbacks == []
    base_config["params"]["config"]["stop_fn"] = "not callable"
    with pytest.raises(ValueError, match="params.config.stop_fn: expected a callable"):
        Runner().load(base_config)
    base_config["params"]["config"].update(stop_fn=None, algo_observer="isac")
    with pytest.raises(ValueError, match="params.config.algo_observer: expected one of default, isaac, got 'isac'"):
        Runner().load(base_config)


def test_partial_config_loads_and_binds_its_vecenv_type(base_config, scoped_registries):
    runner = Runner()  # rl_games' tests load an algo and a config block only: nothing is built until run
    runner.load_config({"algo": {"name": "a2c_continuous"},
                        "config": {"env_name": "partial_test_env", "vecenv_type": "RAY", "reward_shaper": {}}})
    assert runner.algo_name == "a2c_continuous" and ENVS["partial_test_env"] == {"vecenv_type": "RAY"}
    with pytest.raises(ConfigError, match="params.model"):
        runner.create_player()  # used: checked then, one line naming the missing block
    runner.load(base_config)  # a whole config is checked at load, as a YAML is
    assert runner._runner is not None


def test_an_ivecenv_with_another_env_count_is_a_one_line_error():
    from rlchain.envs.backends.rl_games_vecenv import IVecEnvAdapter

    class Fixed(vecenv.IVecEnv):  # built once for 3 envs, as Isaac Lab's env is
        def get_env_info(self):
            return {"observation_space": gym.spaces.Box(-1, 1, (2,)), "action_space": gym.spaces.Discrete(2)}

        def reset(self):
            return torch.zeros(3, 2)

    with pytest.raises(ValueError, match=r"returned 3 observation rows, expected num_actors \(1\) x agents \(1\)"):
        IVecEnvAdapter(Fixed(), 1)
    assert IVecEnvAdapter(Fixed(), 3).num_envs == 3


@pytest.mark.parametrize("module", ["algos_torch.a2c_continuous", "algos_torch.a2c_discrete", "algos_torch.sac_agent",
                                    "algos_torch.central_value", "common.a2c_common", "common.datasets"])
def test_rl_games_agent_modules_say_what_rlchain_offers(module):
    from rlchain.rl_games import alias
    alias.install()
    try:
        with pytest.raises(ImportError, match=r"is rl_games' agent code, not offered by rlchain: rlchain trains") \
                as err:
            importlib.import_module(f"rl_games.{module}")
    finally:
        alias.uninstall()
    assert "\n" not in str(err.value) and err.value.name == f"rl_games.{module}"
