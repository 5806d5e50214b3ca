"""rl_games' public Python API as rl_games behaves: the Runner's algo_factory / player_factory, the
config's env_info / vec_env objects, per-env info lists for observers. Fast: nothing trains here."""

import gymnasium
import numpy as np
import pytest
import torch

from rlchain.envs.backends.rl_games_vecenv import IVecEnvAdapter
from rlchain.rl_games.common import vecenv
from rlchain.rl_games.common.algo_observer import DefaultAlgoObserver
from rlchain.rl_games.torch_runner import Runner
from rlchain.training.events import AlgoObserverCallback


class OwnAgent:
    """An agent a script registers by name, as rl_games users register theirs."""

    made: list = []

    def __init__(self, base_name, params):
        self.base_name, self.params, self.restored, self.trained = base_name, params, None, False
        OwnAgent.made.append(self)

    def restore(self, path):
        self.restored = path

    def train(self):
        self.trained = True
        return "trained"


def test_an_agent_registered_with_algo_factory_is_built_restored_and_trained(base_config):
    runner = Runner()
    runner.algo_factory.register_builder("a2c_discrete", lambda **kwargs: OwnAgent(**kwargs))
    runner.load(base_config)
    assert runner.run({"train": True, "checkpoint": "x.pth"}) == "trained"
    agent = OwnAgent.made[-1]
    assert agent.base_name == "run" and agent.params["config"]["name"] == "t"
    assert agent.restored == "x.pth" and agent.trained
    with pytest.raises(ValueError, match="no_such_algo"):
        runner.algo_factory.create("no_such_algo")


def test_a_player_registered_with_player_factory_is_built_with_params(base_config):
    runner = Runner()
    runner.player_factory.register_builder("a2c_discrete", lambda **kwargs: ("mine", kwargs["params"]["algo"]))
    runner.load(base_config)
    assert runner.create_player() == ("mine", {"name": "a2c_discrete"})


class ListInfoVecEnv(vecenv.IVecEnv):
    """Two envs with one info dict each, as gym-style vector envs return them."""

    def get_env_info(self):
        return {"observation_space": gymnasium.spaces.Box(-1, 1, (4,)), "action_space": gymnasium.spaces.Discrete(2)}

    def reset(self):
        return np.zeros((2, 4), np.float32)

    def step(self, actions):
        infos = [{"scores": 3.0}, {"scores": 5.0}]
        return np.zeros((2, 4), np.float32), np.ones(2, np.float32), np.array([True, False]), infos


def test_config_env_info_and_vec_env_are_read_as_rl_games_reads_them(base_config, scoped_registries):
    env = ListInfoVecEnv()
    base_config["params"]["config"]["env_info"] = env.get_env_info()
    base_config["params"]["config"]["vec_env"] = env
    base_config["params"]["config"]["num_actors"] = 2
    runner = Runner()
    runner.load(base_config)
    assert runner.params["config"]["vec_env"] is env  # kept in the config dict, where rl_games reads it
    player = runner.create_player()
    assert player.env is env and player.observation_space.shape == (4,)


def test_per_env_info_dicts_reach_the_observer_as_a_list():
    adapter = IVecEnvAdapter(ListInfoVecEnv(), 2)
    adapter.reset()
    result = adapter.step(np.zeros(2, np.int64))
    observer = DefaultAlgoObserver()
    seen = []
    observer.process_infos = lambda infos, done: seen.append((infos, done.tolist()))
    AlgoObserverCallback(observer)._process_infos(None, result, torch.tensor([0]), slice(None))
    assert seen == [([{"scores": 3.0}, {"scores": 5.0}], [[0]])]


def test_tracing_adapter_flattens_a_dict_in_and_a_tuple_out():
    from rlchain.rl_games.algos_torch.flatten import TracingAdapter

    class Net(torch.nn.Module):
        def forward(self, input_dict):
            return input_dict["obs"] * 2, input_dict["obs"].sum(-1, keepdim=True), None

    adapter = TracingAdapter(Net(), {"obs": torch.ones(1, 3), "rnn_states": None}, allow_non_tensor=True)
    traced = torch.jit.trace(adapter, adapter.flattened_inputs, check_trace=False)
    doubled, total = traced(torch.full((1, 3), 2.0))
    assert torch.equal(doubled, torch.full((1, 3), 4.0)) and float(total) == 6.0
    with pytest.raises(ValueError, match="allow_non_tensor=False"):
        TracingAdapter(Net(), {"obs": torch.ones(1, 3), "rnn_states": None})


def test_the_player_model_has_rl_games_onnx_recipe_names(base_config):
    runner = Runner()
    runner.load(base_config)
    model = runner.create_player().model
    logits, value, states = model.a2c_network({"obs": model.norm_obs(torch.zeros(1, 4))})
    assert logits.shape == (1, 2) and value.shape == (1, 1)
    # the network is the model's one child under rl_games' name: its keys are rl_games' own, held once
    keys = list(model.state_dict())
    assert keys and all(k.startswith(("a2c_network.", "running_mean_std.", "value_mean_std.")) for k in keys)
    assert "a2c_network.actor_mlp.0.weight" in keys and "a2c_network.logits.weight" in keys
