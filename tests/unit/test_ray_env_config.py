"""Ray env runners without starting Ray: config parsing, the worker split, errors, the worker body."""

import pickle
import sys

import numpy as np
import pytest
import torch

from rlchain.algos.base.episodes import EpisodeTracker
from rlchain.config import ConfigError, parse_params
from rlchain.config.run import EnvRunnersConfig
from rlchain.envs.factory import make_vec_env
from rlchain.envs.ray.ray_env import merge_infos, worker_slices
from rlchain.envs.ray.ray_worker import EnvRecipe, EnvWorker, per_env_infos
from rlchain.models.build import build_env


def parse(cfg):
    return parse_params(cfg, "cfg.yaml")


def sizes(num_envs, **kw):
    return [s.stop - s.start for s in worker_slices(num_envs, EnvRunnersConfig(**kw))]


def test_worker_split():
    assert sizes(8) == [4, 4]  # vecenv_type RAY alone: 2 workers
    assert sizes(1) == [1]  # never more workers than envs
    assert sizes(10, num_workers=3) == [4, 3, 3]  # uneven: the first workers take one more
    assert sizes(12, envs_per_worker=4) == [4, 4, 4]
    assert sizes(6, num_workers=2, envs_per_worker=3) == [3, 3]
    assert [(s.start, s.stop) for s in worker_slices(5, EnvRunnersConfig(num_workers=2))] == [(0, 3), (3, 5)]


@pytest.mark.parametrize("kw,key,text", [
    ({"num_workers": 5}, "num_workers", "5 workers for num_actors 4"),
    ({"envs_per_worker": 3}, "envs_per_worker", "num_actors 4 does not divide by envs_per_worker 3"),
    ({"num_workers": 2, "envs_per_worker": 3}, "envs_per_worker", "2 workers x 3 envs is not num_actors 4"),
])
def test_impossible_split_is_a_one_line_config_error(kw, key, text):
    with pytest.raises(ConfigError) as err:
        worker_slices(4, EnvRunnersConfig(**kw))
    assert str(err.value).startswith(f"params.config.env_runners.{key}: ") and text in str(err.value)
    assert "\n" not in str(err.value)


def test_env_runners_block_parses(base_config):
    cfg = base_config["params"]["config"]
    assert parse(base_config).config.env_runners is None
    cfg["env_runners"] = {"num_workers": 2, "address": "ray://head:10001", "max_restarts": 0}
    runners = parse(base_config).config.env_runners
    assert (runners.num_workers, runners.address, runners.max_restarts) == (2, "ray://head:10001", 0)
    assert runners.step_timeout_s == 60.0 and runners.envs_per_worker is None
    cfg["env_runners"] = {}
    assert parse(base_config).config.env_runners == EnvRunnersConfig()


@pytest.mark.parametrize("block,text", [
    ({"num_worker": 2}, "params.config.env_runners.num_worker: unknown key; did you mean 'num_workers'?"),
    ({"num_workers": 0}, "params.config.env_runners.num_workers: must be > 0"),
    ({"step_timeout_s": -1}, "params.config.env_runners.step_timeout_s: must be > 0"),
    ({"max_restarts": "many"}, "params.config.env_runners.max_restarts: expected an integer"),
])
def test_bad_env_runners_keys(base_config, block, text):
    base_config["params"]["config"]["env_runners"] = block
    with pytest.raises(ConfigError, match="^cfg.yaml: " + text.replace("?", r"\?").replace(".", r"\.")):
        parse(base_config)


def test_without_ray_the_error_names_the_extra(monkeypatch, base_config):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    with pytest.raises(ConfigError) as err:
        make_vec_env("CartPole-v1", {}, 4, 0, "RAY")
    assert str(err.value) == ("params.config.vecenv_type: Ray env runners need ray, which is not installed: "
                              "pip install rlchain[ray]")
    base_config["params"]["config"]["env_runners"] = {"num_workers": 2}
    with pytest.raises(ConfigError, match=r"^cfg\.yaml: params\.config\.env_runners: .*pip install rlchain\[ray\]$"):
        build_env(parse(base_config), 4, 0, runners=True)


def test_play_and_evaluation_envs_stay_local(monkeypatch, base_config):
    """RAY configs play and evaluate on local envs: no Ray is needed (or started) for them."""
    monkeypatch.setitem(sys.modules, "ray", None)
    base_config["params"]["config"]["vecenv_type"] = "RAY"
    base_config["params"]["config"]["env_runners"] = {"num_workers": 2}
    env = build_env(parse(base_config), 3, 0)
    assert type(env).__name__ == "GymnasiumVecEnv" and env.num_envs == 3
    env.close()
    with pytest.raises(ConfigError, match="rendering needs the envs in this process"):
        make_vec_env("CartPole-v1", {}, 1, 0, "RAY", render=True)


def test_worker_body_steps_its_slice_with_global_seeds_and_indices():
    """EnvWorker (the actor's body) run in-process: same envs as the local backend's rows 2..3."""
    worker = EnvWorker(EnvRecipe.capture("CartPole-v1", {"max_episode_steps": 3}, "sync"), start=2, num_envs=2)
    info = worker.build(seed=5 + 2)
    assert info["action_space"].n == 2 and info["value_size"] == 1
    local = make_vec_env("CartPole-v1", {"max_episode_steps": 3}, 4, 5, "sync")
    np.testing.assert_array_equal(worker.reset(7), local.reset(5)[2:])
    for _ in range(3):
        out = worker.step(pickle.dumps(np.ones(2, dtype=np.int64)))
        ref = local.step(np.ones(4, dtype=np.int64))
    obs, reward, terminated, truncated, rows, final, game_reward, game_over, infos = pickle.loads(out)
    np.testing.assert_array_equal(obs, ref.obs[2:])
    assert truncated.all() and rows.tolist() == [0, 1]  # time-out after 3 steps
    np.testing.assert_array_equal(final, ref.final_obs[2:])
    assert reward.dtype == np.float32 and obs.dtype == np.float32 and game_reward is None and game_over is None
    worker.env.env.envs[1].env.step = lambda a: 1 / 0  # env 1 of this worker = env 3 of the batch
    with pytest.raises(RuntimeError, match=r"^env 3 step raised ZeroDivisionError"):
        worker.step(pickle.dumps(np.ones(2, dtype=np.int64)))
    worker.close()
    local.close()


def test_worker_sends_the_infos_per_env_numbers_and_the_learner_merges_them():
    """Success and log_info_keys read the step infos: the workers send each one-number-per-env value
    (and gymnasium's final_info), not per-env vectors or objects; the learner rebuilds one dict."""
    infos = {"success": np.array([0.0, 1.0]), "env_id": np.array([0, 1], np.int32), "_success": np.ones(2, bool),
             "final_obs": np.zeros((2, 4)), "players": {"id": np.zeros(2)}, "label": "x",
             "final_info": {"is_success": np.array([1.0, 0.0]), "_is_success": np.array([True, False])},
             "reward_box_target": torch.tensor([0.5, 0.25])}
    part = per_env_infos(infos, 2)
    assert set(part) == {"success", "env_id", "_success", "final_info", "reward_box_target"}
    assert set(part["final_info"]) == {"is_success", "_is_success"} and per_env_infos(None, 2) == {}
    other = {"success": np.array([1.0]), "_success": np.array([True])}  # a worker without final_info / the term
    merged = merge_infos([part, other, {}], [slice(0, 2), slice(2, 3), slice(3, 5)], 5)
    np.testing.assert_array_equal(merged["success"], [0, 1, 1, np.nan, np.nan])
    assert merged["_success"].tolist() == [True, True, True, False, False]  # a cut worker's rows: absent
    np.testing.assert_array_equal(merged["reward_box_target"], [0.5, 0.25, np.nan, np.nan, np.nan])
    np.testing.assert_array_equal(merged["final_info"]["is_success"], [1, 0, np.nan, np.nan, np.nan])
    assert merged["final_info"]["_is_success"].tolist() == [True, False, False, False, False]
    assert "final_info" not in merge_infos([other], [slice(0, 1)], 1)


def test_tensor_envs_are_refused_on_workers():
    with pytest.raises(ValueError, match="'TorchCartPole-v0' is a tensor env .*; Ray env workers do not support it"):
        EnvRecipe.capture("TorchCartPole-v0", {"device": "cpu"}, "auto").build(2, 0)


def test_recipe_ships_user_registrations():
    """A user env registered in the learner reaches the worker as the builder / gymnasium spec."""
    from rlchain import env_configurations
    from rlchain.registry import ENVS

    env_configurations.register("RayRecipeTest-v0", {"env_creator": lambda **kw: __import__("gymnasium").make(
        "CartPole-v1", **kw)}, overwrite=True)
    recipe = EnvRecipe.capture("RayRecipeTest-v0", {}, "sync")
    assert "RayRecipeTest-v0" in recipe.gym_specs and "CartPole-v1" not in recipe.gym_specs  # only run-time ones
    import gymnasium as gym
    del gym.registry["RayRecipeTest-v0"]  # as in a fresh worker process
    env = recipe.build(2, 0)
    assert env.reset().shape == (2, 4)
    env.close()
    recipe = EnvRecipe.capture("openai_gym", {"name": "Pendulum-v1"}, "auto")
    assert recipe.builders["openai_gym"] is ENVS.get("openai_gym") and "Pendulum-v1" in recipe.gym_specs


def test_episode_tracker_forgets_dropped_rows():
    tracker = EpisodeTracker(3, 10, torch.device("cpu"))
    tracker.step(torch.ones(3), torch.zeros(3, dtype=torch.bool))
    tracker.step(torch.ones(3), torch.tensor([True, True, False]), dropped=np.array([False, True, False]))
    assert list(tracker.finished_returns) == [2.0] and tracker.games == 1  # row 1 was cut, not finished
    assert tracker.returns.tolist() == [0.0, 0.0, 2.0] and tracker.lengths.tolist() == [0, 0, 2]


def test_unreachable_cluster_address_fails_fast_instead_of_hanging():
    """ray.init(address=...) retries for minutes when nothing answers; the address is checked first."""
    import socket
    import time

    ray = pytest.importorskip("ray")
    if ray.is_initialized():
        pytest.skip("this process is connected to Ray already")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # free once closed: nothing listens there
    start = time.monotonic()
    with pytest.raises(ConfigError) as err:
        make_vec_env("CartPole-v1", {}, 2, 0, "RAY", env_runners=EnvRunnersConfig(address=f"127.0.0.1:{port}"))
    assert time.monotonic() - start < 5 and not ray.is_initialized()
    assert str(err.value).startswith(f"params.config.env_runners.address: cannot reach Ray at '127.0.0.1:{port}'")


def test_envs_the_workers_cannot_carry_are_named():
    from types import SimpleNamespace

    from rlchain.envs.ray.ray_worker import _unsupported

    assert _unsupported(SimpleNamespace()) is None
    assert _unsupported(SimpleNamespace(get_number_of_agents=lambda: 2)) == "has several agents per env"
    assert _unsupported(SimpleNamespace(has_action_mask=lambda: True)) == "has action masks"
    assert _unsupported(SimpleNamespace(use_central_value=True)) == "has central-value (dict) observations"
