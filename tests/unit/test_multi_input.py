"""The multi_input network: an encoder per observation key (chosen by shape or named), fused into the
actor-critic trunk; its config keys reject wrong values in one line naming the key."""

import copy

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner
from rlchain.config import ConfigError, parse_params
from rlchain.config.multi_input import InputConfig
from rlchain.envs.obs_dict import ObsDict
from rlchain.models.build import build_env, build_model
from rlchain.networks.multi_input import MultiInputEncoder, random_shift
from tests.conftest import CONFIGS

CONFIG = f"{CONFIGS}/ppo_camera_reach.yaml"
SPACE = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (1, 24, 24), np.uint8),
                         "proprio": gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)})


def _raw():
    import yaml
    with open(CONFIG, encoding="utf-8") as fh:
        return yaml.safe_load(fh)


def _obs(n=3):
    return ObsDict({"image": torch.rand(n, 1, 24, 24), "proprio": torch.randn(n, 4)})


def test_encoders_by_shape_and_by_name():
    auto = MultiInputEncoder(SPACE, {})
    assert type(auto.encoders["image"]).__name__ == "ImageEncoder"
    assert type(auto.encoders["proprio"]).__name__ == "FlatEncoder"
    assert auto(_obs()).shape == (3, auto.out_size)
    named = MultiInputEncoder(SPACE, {"image": InputConfig(encoder="impala", conv_depths=[8], units=[]),
                                      "proprio": InputConfig(encoder="none")})
    assert named.keys == ("image",) and named(_obs()).shape[0] == 3


def test_a_missing_key_is_accepted_only_when_the_network_does_not_read_it():
    unread = MultiInputEncoder(SPACE, {"camera": InputConfig(encoder="none")})
    assert unread.keys == ("image", "proprio") and unread(_obs()).shape == (3, unread.out_size)
    for encoder in ("auto", "cnn", "mlp", "flatten"):
        with pytest.raises(ValueError) as err:
            MultiInputEncoder(SPACE, {"camera": InputConfig(encoder=encoder)})
        assert "params.network.inputs: camera not a key of the observations" in str(err.value)
        assert "\n" not in str(err.value)


def test_model_on_the_camera_task_acts_on_dict_observations():
    params = Runner().load(CONFIG, ["params.config.num_actors=4"]).params
    env = build_env(params, 4, 0)
    model = build_model(params, env, torch.device("cpu"))
    obs = env.reset()
    out = model.act(obs)
    assert out["actions"].shape == (4, 2) and out["values"].shape == (4, 1)
    model.update_normalizers(obs=obs)  # the proprio statistics move, the image has none (scaled /255)
    assert set(model.running_mean_std.running_mean_std) == {"proprio"}
    assert model.running_mean_std.running_mean_std["proprio"].count > 1


def test_actor_critic_network_gets_the_keys_flattened():
    params = Runner().load(CONFIG, ["params.network={name: actor_critic, space: {continuous: {}}, mlp: {units: [8]}}"]
                           ).params
    env = build_env(params, 2, 0)
    model = build_model(params, env, torch.device("cpu"))
    assert model.flatten_dict
    assert model.act(env.reset())["actions"].shape == (2, 2)


def test_random_shift_moves_images_by_at_most_pad_pixels():
    image = torch.zeros(16, 1, 8, 8)
    image[:, :, 4, 4] = 1.0
    shifted = random_shift(image, 2)
    assert shifted.shape == image.shape
    where = shifted.view(16, -1).argmax(1)
    assert ((where // 8 - 4).abs() <= 2).all() and ((where % 8 - 4).abs() <= 2).all()


@pytest.mark.parametrize("path, value, message", [
    (("network", "inputs", "image", "encoder"), "resnet", "params.network.inputs.image.encoder: 'resnet' is not one"),
    (("network", "inputs", "image", "random_shift"), -1, "params.network.inputs.image.random_shift"),
    (("network", "inputs", "image", "units"), [0], "params.network.inputs.image.units"),
    (("network", "inputs", "image", "conv_depths"), [], "params.network.inputs.image.conv_depths"),
    (("network", "inputs", "image", "convs"), [], "params.network.inputs.image.convs"),
    (("network", "inputs", "image", "activation"), "rleu", "params.network.inputs.image.activation"),
    (("network", "inputs", "image", "permute_input"), "maybe", "params.network.inputs.image.permute_input"),
    (("network", "inputs", "image", "kernel"), 3, "params.network.inputs.image.kernel"),
    (("network", "inputs"), [1], "params.network.inputs: expected a mapping"),
    (("network", "cnn"), {"convs": [{"filters": 4, "kernel_size": 3}]}, "params.network.cnn: not used by multi_input"),
    (("config", "obs_normalizer_exclude"), "proprio", "params.config.obs_normalizer_exclude"),
    (("config", "obs_normalizer_exclude"), [""], "params.config.obs_normalizer_exclude"),
])
def test_wrong_values_are_one_line_errors_naming_the_key(path, value, message):
    raw = copy.deepcopy(_raw())
    block = raw["params"]
    for key in path[:-1]:
        block = block[key]
    block[path[-1]] = value
    with pytest.raises(ConfigError) as err:
        parse_params(raw, "cfg.yaml")
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("override, message", [
    ("params.network.inputs.camera={encoder: cnn}", "params.network.inputs: camera not a key of the observations"),
    ("params.network.inputs.proprio.encoder=cnn", "params.network.inputs.proprio.encoder: cnn needs an image"),
    ("params.config.obs_normalizer_exclude=[joints]", "params.config.obs_normalizer_exclude: ['joints'] are not keys"),
])
def test_keys_that_do_not_fit_the_env_are_one_line_errors(override, message):
    params = Runner().load(CONFIG, ["params.config.num_actors=2", override]).params
    env = build_env(params, 2, 0)
    with pytest.raises((ConfigError, ValueError)) as err:
        build_model(params, env, torch.device("cpu"))
    assert message in str(err.value) and "\n" not in str(err.value)


def test_multi_input_on_a_box_observation_says_what_it_needs():
    params = Runner().load(CONFIG, ["params.config.env_config.observation=proprio"]).params
    env = build_env(params, 2, 0)
    with pytest.raises((ConfigError, ValueError), match="multi_input needs Dict observations"):
        build_model(params, env, torch.device("cpu"))


@pytest.mark.parametrize("extra", [[], ["params.network.rnn={name: gru, units: 16}", "params.config.seq_length=5"]])
def test_onnx_export_takes_one_named_input_per_key(tmp_path, extra):
    pytest.importorskip("onnxruntime")
    from rlchain.inference.export.onnx import export_model_onnx, onnx_session, random_observations, verify_onnx

    params = Runner().load(CONFIG, ["params.config.num_actors=4", *extra]).params
    env = build_env(params, 4, 0)
    model = build_model(params, env, torch.device("cpu"))
    model.update_normalizers(obs=env.reset())  # statistics that are not the identity
    model.eval()
    path = export_model_onnx(model, env.observation_space, str(tmp_path / "camera.onnx"))
    session = onnx_session(path)
    inputs = session.get_inputs()
    assert [i.name for i in inputs][:2] == ["image", "proprio"]
    assert inputs[0].type == "tensor(uint8)" and inputs[1].type == "tensor(float)"
    random = random_observations(env.observation_space, 16)
    assert verify_onnx(model, path, random, session, steps=3) < 1e-5
    real = env.reset()
    assert verify_onnx(model, path, {k: v.numpy() for k, v in real.items()}, session) < 1e-5


ASYMMETRIC = ["params.config.num_actors=4", "params.config.env_config.privileged=True",
              "params.network.inputs.goal={encoder: none}",
              "params.config.central_value_config={network: {name: multi_input, inputs: {image: {encoder: none}, "
              "goal: {encoder: mlp, units: [8]}}, mlp: {units: [16]}}}"]


def test_central_value_reads_its_own_keys():
    from rlchain.models.build import build_central_value

    params = Runner().load(CONFIG, ASYMMETRIC).params
    env = build_env(params, 4, 0)
    model = build_model(params, env, torch.device("cpu"))
    critic = build_central_value(params, env, torch.device("cpu"))
    assert model.a2c_network.actor_cnn.keys == ("image", "proprio")  # the actor never reads the goal
    assert critic.a2c_network.actor_cnn.keys == ("goal", "proprio")  # the critic reads the privileged goal
    obs = env.reset()
    assert critic.value(obs).shape == (4, 1)
    critic.update_normalizers(obs=obs)
    assert set(critic.running_mean_std.running_mean_std) == {"goal", "proprio"}


def test_central_value_on_dict_observations_needs_multi_input():
    from rlchain.models.build import build_central_value

    over = [*ASYMMETRIC[:3], "params.config.central_value_config={network: {name: actor_critic, mlp: {units: [8]}}}"]
    params = Runner().load(CONFIG, over).params
    env = build_env(params, 4, 0)
    with pytest.raises(ConfigError, match="central_value_config.network.name: the observations are a Dict"):
        build_central_value(params, env, torch.device("cpu"))


SAC_NETWORK = ["params.algo.name=sac", "params.model.name=soft_actor_critic", "params.config={name: camera_sac, "
               "env_name: TorchCameraReach-v0, env_config: {device: cpu}, device: cpu, normalize_input: True}",
               "params.network.mlp={units: [16], activation: relu}", "params.network.space={continuous: {}}"]
DQN_SPACE = gym.spaces.Dict({"image": gym.spaces.Box(0, 255, (8, 8, 3), np.uint8),
                             "vec": gym.spaces.Box(-1, 1, (2,), np.float32)})


class _DictSpaces:
    """What build_model reads of an env: the spaces (a Dict kept per key) and the count."""

    num_envs = 1

    def __init__(self, observation_space, action_space):
        self.observation_space, self.action_space = observation_space, action_space


def _dqn_params(network=""):
    raw = {"params": {"algo": {"name": "dqn"}, "model": {"name": "dqn"},
                      "network": {"name": "multi_input", "mlp": {"units": [16]}},
                      "config": {"name": "side", "env_name": "CartPole-v1", "normalize_input": True}}}
    if network:
        raw["params"]["network"].update(network)
    return parse_params(raw, "cfg.yaml")


def test_sac_gets_an_encoder_for_the_actor_and_one_for_the_twin_critics():
    params = Runner().load(CONFIG, SAC_NETWORK).params
    env = build_env(params, 3, 0)
    model = build_model(params, env, torch.device("cpu"))
    net = model.network
    assert isinstance(net.actor.encoder, MultiInputEncoder) and isinstance(net.critic.encoder, MultiInputEncoder)
    assert net.actor.encoder is not net.critic.encoder
    assert model.critic_target.encoder is not net.critic.encoder  # the target critic has its own (Polyak) copy
    obs = env.reset()
    assert model.act(obs)["actions"].shape == (3, 2)
    model.update_normalizers(obs=obs)
    # the image is scaled, the proprioception normalized
    assert set(model.running_mean_std.running_mean_std) == {"proprio"}
    # the critic's loss reaches the critic's encoder only
    x = model.preprocess(obs)
    q1, q2 = net.critic(x, torch.zeros(3, 2))
    (q1 + q2).sum().backward()
    assert all(p.grad is None for p in net.actor.parameters())
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in net.critic.encoder.parameters())


@pytest.mark.parametrize("dueling, heads", [(None, True), (False, False)])
def test_dqn_q_network_on_per_key_encoders(dueling, heads):
    params = _dqn_params({} if dueling is None else {"dueling": dueling})
    model = build_model(params, _DictSpaces(DQN_SPACE, gym.spaces.Discrete(3)), torch.device("cpu"))
    assert isinstance(model.network.encoder, MultiInputEncoder)
    assert (model.network.state_value is not None) == heads
    obs = ObsDict({"image": torch.randint(0, 256, (5, 8, 8, 3), dtype=torch.uint8), "vec": torch.rand(5, 2)})
    out = model.act(obs, deterministic=True)
    assert out["actions"].shape == (5,) and out["q"].shape == (5, 3)


@pytest.mark.parametrize("network, message", [
    ({"dueling": "maybe"}, "params.network.dueling"),
    ({"rnn": {"name": "gru", "units": 8}}, "takes no rnn or history"),
])
def test_dqn_wrong_network_values_are_one_line_errors(network, message):
    with pytest.raises((ConfigError, ValueError)) as err:
        build_model(_dqn_params(network), _DictSpaces(DQN_SPACE, gym.spaces.Discrete(3)), torch.device("cpu"))
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("extra", [SAC_NETWORK, []], ids=["sac", "ppo"])
def test_dueling_outside_dqn_is_a_one_line_error(extra):
    params = Runner().load(CONFIG, [*extra, "params.network.dueling=True"]).params
    env = build_env(params, 2, 0)
    with pytest.raises((ConfigError, ValueError)) as err:
        build_model(params, env, torch.device("cpu"))
    assert "params.network.dueling" in str(err.value) and "\n" not in str(err.value)


def test_sac_onnx_export_takes_one_named_input_per_key(tmp_path):
    pytest.importorskip("onnxruntime")
    from rlchain.inference.export.onnx import export_model_onnx, onnx_session, verify_onnx

    params = Runner().load(CONFIG, SAC_NETWORK).params
    env = build_env(params, 4, 0)
    model = build_model(params, env, torch.device("cpu"))
    model.update_normalizers(obs=env.reset())
    model.eval()
    path = export_model_onnx(model, env.observation_space, str(tmp_path / "camera_sac.onnx"))
    session = onnx_session(path)
    assert [i.name for i in session.get_inputs()][:2] == ["image", "proprio"]
    real = env.reset()
    assert verify_onnx(model, path, {k: v.numpy() for k, v in real.items()}, session) < 1e-5


@pytest.mark.parametrize("value, message", [
    ("proprio", "params.config.obs_normalizer_exclude: expected a list"),
    ("[joints]", "params.config.obs_normalizer_exclude: ['joints'] are not keys"),
])
def test_sac_obs_normalizer_exclude_wrong_values(value, message):
    with pytest.raises((ConfigError, ValueError)) as err:
        params = Runner().load(CONFIG, [*SAC_NETWORK, f"params.config.obs_normalizer_exclude={value}"]).params
        build_model(params, build_env(params, 2, 0), torch.device("cpu"))
    assert message in str(err.value) and "\n" not in str(err.value)


def test_sac_obs_normalizer_exclude_leaves_the_key_as_it_is():
    params = Runner().load(CONFIG, [*SAC_NETWORK, "params.config.obs_normalizer_exclude=[proprio]"]).params
    model = build_model(params, build_env(params, 2, 0), torch.device("cpu"))
    assert len(model.running_mean_std.running_mean_std) == 0


KEYED = gym.spaces.Dict({"pos": gym.spaces.Box(-1, 1, (3,), np.float32), "room": gym.spaces.Discrete(4, start=1),
                         "cell": gym.spaces.MultiDiscrete([3, 5])})


class Rooms(gym.Env):
    """A gymnasium Dict env with a vector, a Discrete key (start 1) and a MultiDiscrete key; 10-step episodes."""

    observation_space = KEYED
    action_space = gym.spaces.Discrete(2)

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self.observation_space.sample(), {}

    def step(self, action):
        self.t += 1
        return self.observation_space.sample(), float(action), False, self.t >= 10, {}


def _rooms(extra=()):
    if "RoomsTest-v0" not in gym.registry:
        gym.register("RoomsTest-v0", entry_point=Rooms)
    over = ["params.config.env_name=RoomsTest-v0", "params.network.name=multi_input", "params.network.mlp.units=[8]",
            "params.config.num_actors=3", "params.config.normalize_input=true", "params.config.vecenv_type=sync",
            *extra]
    params = Runner().load(f"{CONFIGS}/ppo_cartpole.yaml", over).params
    env = build_env(params, 3, 0)
    return params, env, build_model(params, env, torch.device("cpu"))


def test_discrete_keys_get_an_embedding_of_their_values():
    from rlchain.networks.multi_input import EmbeddingEncoder

    enc = MultiInputEncoder(KEYED, {"cell": InputConfig(dim=3)})
    assert {k: type(e).__name__ for k, e in enc.encoders.items()} == {
        "pos": "FlatEncoder", "room": "EmbeddingEncoder", "cell": "EmbeddingEncoder"}
    room, cell = enc.encoders["room"], enc.encoders["cell"]
    assert room.out_size == 16 and cell.out_size == 2 * 3 and enc.out_size == 64 + 16 + 6
    assert room.table.num_embeddings == 4 and cell.table.num_embeddings == 3 + 5
    # the env's values (start 1) pick rows 0..3; a MultiDiscrete's components their own rows of one table
    assert torch.equal(room(torch.tensor([1, 4])), room.table.weight[[0, 3]])
    assert torch.equal(cell(torch.tensor([[2, 0], [0, 4]])), cell.table.weight[[2, 3, 0, 7]].reshape(2, 6))
    obs = ObsDict({"pos": torch.randn(5, 3), "room": torch.randint(1, 5, (5,)), "cell": torch.randint(0, 3, (5, 2))})
    assert enc(obs).shape == (5, enc.out_size)
    assert isinstance(room, EmbeddingEncoder)
    one_hot = MultiInputEncoder(KEYED, {"room": InputConfig(encoder="flatten"), "cell": InputConfig(encoder="none")})
    assert torch.equal(one_hot.encoders["room"](torch.tensor([1, 3])), torch.eye(4)[[0, 2]])


def test_a_gymnasium_env_s_discrete_keys_reach_the_network_as_integers_never_normalized():
    params, env, model = _rooms()
    assert type(env).__name__ == "StatefulPerKeyObs" and env.observation_space == KEYED
    obs = env.reset()
    assert obs["room"].dtype == np.int64 and obs["room"].shape == (3,) and obs["cell"].shape == (3, 2)
    assert ((obs["room"] >= 1) & (obs["room"] <= 4)).all()  # the env's values, start included (not the one-hot)
    from rlchain.algos.core.storage import obs_buffer_layout, rollout_step_bytes
    from rlchain.envs.obs_dict import dict_zeros, obs_as_tensor

    layout, _ = obs_buffer_layout(env.observation_space)
    assert dict_zeros((2, 3), layout)["room"].dtype == torch.int64
    assert rollout_step_bytes(KEYED, env.action_space, 1) - rollout_step_bytes(
        gym.spaces.Dict({"pos": KEYED["pos"]}), env.action_space, 1) == 3 * 8  # room + cell: three int64
    batch = obs_as_tensor(obs, "cpu")
    model.update_normalizers(obs=batch)
    assert set(model.running_mean_std.running_mean_std) == {"pos"}
    seen = model.running_mean_std.normalize(batch)
    assert torch.equal(seen["room"], batch["room"]) and seen["room"].dtype == torch.int64
    assert model.act(batch)["actions"].shape == (3,)
    env.close()


def test_a_flat_network_reads_discrete_keys_as_numbers():
    _, env, model = _rooms(["params.network.name=actor_critic"])
    assert type(env).__name__ == "GymnasiumVecEnv" and env.observation_space.shape == (3 + 4 + 8,)  # gym's one-hot
    assert model.act(torch.as_tensor(env.reset()))["actions"].shape == (3,)
    env.close()


def test_onnx_export_takes_a_discrete_key_as_an_int64_input(tmp_path):
    pytest.importorskip("onnxruntime")
    from rlchain.inference.export.onnx import export_model_onnx, onnx_session, random_observations, verify_onnx

    _, env, model = _rooms()
    model.eval()
    path = export_model_onnx(model, env.observation_space, str(tmp_path / "rooms.onnx"))
    session = onnx_session(path)
    types = {i.name: i.type for i in session.get_inputs()}
    assert types == {"pos": "tensor(float)", "room": "tensor(int64)", "cell": "tensor(int64)"}
    assert verify_onnx(model, path, random_observations(env.observation_space, 16), session) < 1e-5
    assert verify_onnx(model, path, env.reset(), session) < 1e-5
    env.close()


@pytest.mark.parametrize("inputs, message", [
    ("{pos: {encoder: embedding}}", "params.network.inputs.pos.encoder: embedding needs a Discrete or MultiDiscrete"),
    ("{room: {encoder: cnn}}", "params.network.inputs.room.encoder: cnn needs an image"),
    ("{room: {dim: 0}}", "params.network.inputs.room.dim"),
    ("{room: {dim: four}}", "params.network.inputs.room.dim"),
])
def test_embedding_keys_reject_wrong_values_in_one_line(inputs, message):
    with pytest.raises((ConfigError, ValueError)) as err:
        _rooms([f"params.network.inputs={inputs}"])
    assert message in str(err.value) and "\n" not in str(err.value)
