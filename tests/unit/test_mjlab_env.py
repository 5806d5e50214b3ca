"""The mjlab backend (rlchain/envs/backends/mjlab_env.py) on a stand-in for mjlab's ManagerBasedRlEnv: no mjlab
needed. The real tasks run in tests/smoke/test_mjlab_configs.py (skipped without mjlab)."""

import copy
import os
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.config.errors import ConfigError
from rlchain.envs.backends import mjlab_env
from rlchain.envs.wrappers.central_value import ObsStateBox
from rlchain.models.build import build_central_value, build_env, build_model

ACTOR, CRITIC, ACTIONS = 3, 5, 2


class FakeManagerBasedRlEnv:
    """mjlab's env surface the backend reads: dict observations by group, (obs, rew, term, trunc, extras) steps
    with a reused ``extras['log']``. The actor group of row i at step t is ``[t, i, 1]``, the critic group
    ``[100 + t, i, 2, 3, 4]``; env 0 times out every 3 steps, env 1 terminates every 4."""

    def __init__(self, num_envs=4, critic=True, finite_horizon=False):
        self.num_envs, self.device, self.critic = num_envs, "cpu", critic
        self.cfg = SimpleNamespace(is_finite_horizon=finite_horizon)
        self.single_action_space = gym.spaces.Box(-np.inf, np.inf, (ACTIONS,), np.float32)
        self.max_episode_length = 10
        self.episode_length_buf = torch.zeros(num_envs, dtype=torch.long)
        self.extras = {"log": {}}
        self.t, self.seeds, self.closed, self.actions = 0, [], False, None

    def _obs(self):
        rows = torch.arange(self.num_envs, dtype=torch.float32)
        t = torch.full((self.num_envs,), float(self.t))
        obs = {"actor": torch.stack([t, rows, torch.ones(self.num_envs)], -1)}
        if self.critic:
            obs["critic"] = torch.stack([100 + t, rows, *(torch.full_like(rows, v) for v in (2, 3, 4))], -1)
        return obs

    def reset(self, seed=None):
        if seed is not None:
            self.seeds.append(seed)
        self.t = 0
        return self._obs(), self.extras

    def step(self, actions):
        self.actions = actions
        self.t += 1
        truncated = torch.zeros(self.num_envs, dtype=torch.bool)
        terminated = torch.zeros(self.num_envs, dtype=torch.bool)
        truncated[0] = self.t % 3 == 0
        terminated[1] = self.t % 4 == 0
        self.extras["log"].clear()
        if bool((truncated | terminated).any()):
            self.extras["log"].update({"Episode_Reward/track": torch.tensor(float(self.t)),
                                       "Episode_Termination/time_out": torch.tensor(float(truncated.sum()))})
        return self._obs(), torch.full((self.num_envs,), 0.5), terminated, truncated, self.extras

    def seed(self, seed):
        self.seeds.append(seed)
        return seed

    def close(self):
        self.closed = True


@pytest.fixture
def fake_mjlab(monkeypatch):
    """``build_mjlab_env`` returns a FakeManagerBasedRlEnv; the calls it got are recorded."""
    calls = []

    def build(task_name, num_envs, seed, device, play=False):
        calls.append({"task_name": task_name, "num_envs": num_envs, "seed": seed, "device": device, "play": play})
        return FakeManagerBasedRlEnv(num_envs)

    monkeypatch.setattr(mjlab_env, "build_mjlab_env", build)
    return calls


def test_actor_and_critic_groups_make_an_obs_state_layout():
    env = mjlab_env.MjlabVecEnv(FakeManagerBasedRlEnv(4))
    assert isinstance(env.observation_space, ObsStateBox)
    assert (env.observation_space.obs_size, env.observation_space.state_size) == (ACTOR, CRITIC)
    assert env.use_central_value and env.is_tensor_env and env.action_space.shape == (ACTIONS,)
    obs = env.reset()
    assert obs.shape == (4, ACTOR + CRITIC)
    assert obs[2].tolist() == [0, 2, 1, 100, 2, 2, 3, 4]
    alone = mjlab_env.MjlabVecEnv(FakeManagerBasedRlEnv(4, critic=False))
    assert alone.observation_space.shape == (ACTOR,) and not alone.use_central_value


def test_step_splits_time_outs_from_terminations_and_copies_the_episode_log():
    fake = FakeManagerBasedRlEnv(4)
    env = mjlab_env.MjlabVecEnv(fake)
    first = env.reset()
    result = env.step(np.zeros((4, ACTIONS), np.float32))
    assert fake.actions.dtype == torch.float32 and torch.equal(result.final_obs, first)  # V(s_T-1) bootstrap
    assert "episode" not in result.infos
    for _ in range(2):
        result = env.step(torch.zeros(4, ACTIONS))
    assert result.truncated.tolist() == [True, False, False, False] and not result.terminated.any()
    assert result.infos["time_outs"] is result.truncated
    episode = result.infos["episode"]
    assert float(episode["Episode_Reward/track"]) == 3.0
    fake.extras["log"]["Episode_Reward/track"].fill_(-1.0)  # mjlab reuses its tensors: the copy must not move
    assert float(episode["Episode_Reward/track"]) == 3.0
    result = env.step(torch.zeros(4, ACTIONS))
    assert result.terminated.tolist() == [False, True, False, False] and not result.truncated.any()
    assert env.log_stats() == {"Episode_Reward/track": 3.5, "Episode_Termination/time_out": 0.5}
    assert env.log_stats() == {}


def test_a_finite_horizon_task_times_out_terminally():
    env = mjlab_env.MjlabVecEnv(FakeManagerBasedRlEnv(2, finite_horizon=True))
    env.reset()
    for _ in range(3):
        result = env.step(torch.zeros(2, ACTIONS))
    assert result.terminated.tolist() == [True, False] and not result.truncated.any()


def test_random_episode_start_spreads_the_first_time_outs():
    fake = FakeManagerBasedRlEnv(64)
    env = mjlab_env.MjlabVecEnv(fake, random_episode_start=True)
    env.reset()
    assert int(fake.episode_length_buf.max()) < fake.max_episode_length and len(fake.episode_length_buf.unique()) > 1


def test_both_spellings_build_with_seed_and_device(fake_mjlab):
    env = mjlab_env.mjlab_env(4, 7, task_name="Mjlab-Velocity-Flat-Unitree-Go1", device="cpu")
    rl_games = mjlab_env.mjlab_vecenv("mjlab_go1_velocity", 8, seed=3, task_name="Mjlab-Lift-Cube-Yam",
                                      device="cpu", play=True)
    assert (env.num_envs, rl_games.num_envs) == (4, 8)
    assert fake_mjlab == [{"task_name": "Mjlab-Velocity-Flat-Unitree-Go1", "num_envs": 4, "seed": 7, "device": "cpu",
                           "play": False},
                          {"task_name": "Mjlab-Lift-Cube-Yam", "num_envs": 8, "seed": 3, "device": "cpu", "play": True}]


@pytest.mark.parametrize("env_config, key, text", [
    ({}, "task_name", "is required"),
    ({"task_name": "T", "taks": 1}, "taks", "not an mjlab option"),
    ({"task_name": "T", "play": "yes"}, "play", "true or false"),
    ({"task_name": "T", "device": "gpu0"}, "device", "not a device"),
])
def test_config_mistakes_are_one_line_errors_naming_the_key(fake_mjlab, env_config, key, text):
    with pytest.raises(ConfigError, match=rf"env_config\.{key}.*{text}"):
        mjlab_env.mjlab_env(2, 0, **env_config)


def test_missing_mjlab_names_the_extra(monkeypatch):
    import builtins

    real = builtins.__import__

    def no_mjlab(name, *args, **kwargs):
        if name.startswith("mjlab"):
            raise ImportError(f"No module named '{name}'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_mjlab)
    with pytest.raises(ImportError, match=r"pip install rlchain\[mjlab\]"):
        mjlab_env.build_mjlab_env("Mjlab-Velocity-Flat-Unitree-Go1", 2, 0, "cpu")


CONFIG = {
    "params": {
        "seed": 3,
        "algo": {"name": "a2c_continuous"},
        "model": {"name": "continuous_a2c_logstd"},
        "network": {"name": "actor_critic", "separate": False, "mlp": {"units": [8]},
                    "space": {"continuous": {"fixed_sigma": True, "sigma_init": {"name": "const_initializer",
                                                                                  "val": 0}}}},
        "config": {"name": "mjlab_test", "env_name": "mjlab_go1_velocity", "vecenv_type": "MJLAB",
                   "env_config": {"task_name": "Mjlab-Velocity-Flat-Unitree-Go1", "device": "cpu"},
                   "device": "cpu", "num_actors": 4, "horizon_length": 4, "minibatch_size": 16, "mini_epochs": 1,
                   "normalize_input": False, "max_epochs": 1,
                   "central_value_config": {"minibatch_size": 16, "mini_epochs": 1, "learning_rate": 1e-3,
                                            "normalize_input": False,
                                            "network": {"name": "actor_critic", "central_value": True,
                                                        "mlp": {"units": [8]}}}},
    }
}


def _first_linear_input(module: torch.nn.Module, call) -> torch.Tensor:
    """What the first Linear layer of ``module`` is given when ``call()`` runs."""
    seen = []
    linear = next(m for m in module.modules() if isinstance(m, torch.nn.Linear))
    handle = linear.register_forward_pre_hook(lambda _m, args: seen.append(args[0].detach().clone()))
    try:
        call()
    finally:
        handle.remove()
    return seen[0]


def test_the_actor_group_reaches_the_policy_and_the_critic_group_the_central_value(fake_mjlab):
    params = Runner().load(copy.deepcopy(CONFIG)).params
    env = build_env(params, 4, 3, runners=True)
    model = build_model(params, env, torch.device("cpu"))
    central_value = build_central_value(params, env, torch.device("cpu"))
    obs = env.reset()
    actor_in = _first_linear_input(model, lambda: model.act(obs))
    critic_in = _first_linear_input(central_value, lambda: central_value.value(obs, ()))
    assert torch.equal(actor_in, obs[:, :ACTOR]) and actor_in[1].tolist() == [0, 1, 1]
    assert torch.equal(critic_in, obs[:, ACTOR:]) and critic_in[1].tolist() == [100, 1, 2, 3, 4]
    env.close()


def test_an_rl_games_mjlab_config_trains_an_epoch_with_its_episode_log(fake_mjlab, tmp_path):
    overrides = [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
                 "params.config.log_info_keys=[Episode_Reward/track]"]
    result = Runner().load(copy.deepcopy(CONFIG), overrides).train()
    assert result.epoch == 1
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(os.path.join(result.run_dir, "summaries"))
    events.Reload()
    tags = set(events.Tags()["scalars"])
    # log_info_keys reads infos['episode']; log_stats writes the whole log under rsl_rl's names
    assert {"env_info/Episode_Reward/track", "Episode_Reward/track", "Episode_Termination/time_out"} <= tags
    assert fake_mjlab[0]["seed"] is not None and fake_mjlab[0]["task_name"] == "Mjlab-Velocity-Flat-Unitree-Go1"


def test_an_mjlab_policy_exports_to_onnx_on_the_whole_observation_or_the_actor_group(fake_mjlab, tmp_path):
    pytest.importorskip("onnxruntime")
    import onnx

    from rlchain.inference.export.onnx import export_onnx

    sizes = {}
    for name, extra in (("whole", []), ("actor", ["params.config.obs_groups={teacher: [obs]}"])):
        overrides = [f"params.config.train_dir={tmp_path / name}", "params.config.print_stats=false", *extra]
        runner = Runner().load(copy.deepcopy(CONFIG), overrides)
        result = runner.train()
        out = export_onnx(runner.params, os.path.join(result.run_dir, "nn", "last_mjlab_test.pth"),
                          str(tmp_path / f"{name}.onnx"))
        sizes[name] = onnx.load(out).graph.input[0].type.tensor_type.shape.dim[1].dim_value
    assert sizes == {"whole": ACTOR + CRITIC, "actor": ACTOR}


class TermsKeptApart(FakeManagerBasedRlEnv):
    """The actor group with its terms kept apart (mjlab's ``concatenate_terms: False``): ``joints`` (2) and
    ``phase`` (1), the same values as the concatenated group."""

    def _obs(self):
        obs = super()._obs()
        actor = obs["actor"]
        return {**obs, "actor": {"joints": actor[:, :2], "phase": actor[:, 2:]}}


PER_KEY = {"name": "multi_input", "inputs": {"critic": {"encoder": "none"}}, "mlp": {"units": [8]},
           "space": CONFIG["params"]["network"]["space"]}


@pytest.mark.parametrize("terms", [False, True])
def test_a_multi_input_network_gets_the_observation_groups_per_key(fake_mjlab, monkeypatch, terms):
    if terms:
        monkeypatch.setattr(mjlab_env, "build_mjlab_env", lambda *a, **k: TermsKeptApart(4))
    config = copy.deepcopy(CONFIG)
    config["params"]["network"] = copy.deepcopy(PER_KEY)
    config["params"]["config"]["central_value_config"]["network"] = {
        "name": "multi_input", "inputs": {"critic": {"encoder": "mlp", "units": [8]}}, "mlp": {"units": [8]}}
    params = Runner().load(config).params
    env = build_env(params, 4, 3, runners=True)
    actor_keys = ("actor/joints", "actor/phase") if terms else ("actor",)
    assert tuple(env.observation_space.spaces) == (*actor_keys, "critic") and not env.use_central_value
    obs = env.reset()
    assert obs["critic"][1].tolist() == [100, 1, 2, 3, 4]
    assert torch.cat([obs[k].reshape(4, -1) for k in actor_keys], -1)[1].tolist() == [0, 1, 1]
    model = build_model(params, env, torch.device("cpu"))
    central_value = build_central_value(params, env, torch.device("cpu"))
    assert model.a2c_network.actor_cnn.keys == actor_keys  # the actor never reads the critic group
    assert central_value.a2c_network.actor_cnn.keys == (*actor_keys, "critic")
    assert model.act(obs)["actions"].shape == (4, ACTIONS) and central_value.value(obs, ()).shape == (4, 1)
    env.close()
