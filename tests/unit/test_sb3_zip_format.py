"""rlchain.sb3.zip_format: Stable-Baselines3's .zip models read as data (tests/data/sb3, written by real SB3 with
make_sb3_models.py; expected.json holds SB3's own actions and returns)."""

import json
import os
import zipfile

import gymnasium as gym
import numpy as np
import pytest
import torch

import rlchain
from rlchain.runs.checkpoint import CheckpointError
from rlchain.sb3.zip_format import is_sb3_archive, read_sb3_archive

DATA = os.path.join(os.path.dirname(__file__), os.pardir, "data", "sb3")
EXPECTED = json.load(open(os.path.join(DATA, "expected.json")))
CLASSES = {"ppo_cartpole": "PPO", "ppo_pendulum": "PPO", "sac_pendulum": "SAC", "dqn_cartpole": "DQN"}


def episode_return(model, env_id, seed):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=seed)
    total, done = 0.0, False
    while not done:
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, _ = env.step(action)
        total, done = total + float(reward), terminated or truncated
    return total


@pytest.mark.parametrize("name", list(CLASSES))
def test_sb3_archive_plays_as_sb3_plays_it(name):
    expected = EXPECTED[name]
    model = getattr(rlchain, CLASSES[name]).load(os.path.join(DATA, name))  # SB3's '.zip' found as SB3 finds it
    actions, _ = model.predict(np.asarray(expected["obs"], np.float32))
    np.testing.assert_allclose(np.asarray(actions, np.float64).reshape(-1),
                               np.asarray(expected["actions"], np.float64).reshape(-1), atol=1e-4)
    for seed, sb3_return in expected["returns"].items():
        assert episode_return(model, expected["env_id"], int(seed)) == pytest.approx(sb3_return, abs=1e-2)


def test_archive_contents_are_read_from_json_fields_and_weights():
    archive = read_sb3_archive(os.path.join(DATA, "ppo_pendulum.zip"), "ppo")
    assert archive.observation_space == gym.spaces.Box(np.array([-1, -1, -8], np.float32),
                                                       np.array([1, 1, 8], np.float32), (3,), np.float32)
    assert archive.action_space.shape == (1,) and archive.action_space.high[0] == 2.0
    assert archive.policy_kwargs == {"net_arch": [16], "activation_fn": "Tanh"}
    assert archive.hyperparameters["n_steps"] == 128 and archive.hyperparameters["clip_range"] == 0.2
    assert archive.num_timesteps == 256
    sac = read_sb3_archive(os.path.join(DATA, "sac_pendulum.zip"), "sac")
    assert "log_alpha" in sac.policy_state and sac.hyperparameters["ent_coef"] == "auto"


def test_archives_naming_code_or_of_another_algorithm_are_refused(tmp_path):
    path = str(tmp_path / "evil.zip")
    with zipfile.ZipFile(os.path.join(DATA, "dqn_cartpole.zip")) as src, zipfile.ZipFile(path, "w") as dst:
        dst.writestr("data", src.read("data"))
        with dst.open("policy.pth", "w") as fh:
            torch.save({"q_net.q_net.0.weight": torch.zeros(1), "hook": os.system}, fh)
    assert is_sb3_archive(path)
    with pytest.raises(CheckpointError, match=r"evil.zip: 'policy.pth' refused: it names 'posix.system'"):
        rlchain.DQN.load(path)
    with pytest.raises(CheckpointError, match="not an SB3 PPO MlpPolicy"):
        rlchain.PPO.load(os.path.join(DATA, "dqn_cartpole.zip"))


def _rewrite_data(src, dst, change):
    """A copy of archive ``src`` at ``dst`` with its ``data`` JSON passed through ``change``."""
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(dst, "w") as b:
        for name in a.namelist():
            b.writestr(name, json.dumps(change(json.loads(a.read(name)))) if name == "data" else a.read(name))
    return dst


def test_spaces_saved_by_sb3_before_2_are_read(tmp_path):
    def old_gym(data):  # SB3 1.x with gym: 'shape' as text, no '_shape'
        for key in ("observation_space", "action_space"):
            space = data[key]
            space["shape"] = str(list(space.pop("_shape", []))).replace(",", "")
        return data
    path = _rewrite_data(os.path.join(DATA, "ppo_pendulum.zip"), str(tmp_path / "old.zip"), old_gym)
    archive, new = read_sb3_archive(path, "ppo"), read_sb3_archive(os.path.join(DATA, "ppo_pendulum.zip"), "ppo")
    assert archive.observation_space == new.observation_space and archive.action_space == new.action_space


def test_sac_entropy_coefficient_of_sb3_before_1_is_read(tmp_path):
    src, path = os.path.join(DATA, "sac_pendulum.zip"), str(tmp_path / "old_sac.zip")
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(path, "w") as b:  # SB3 < 1 named it tensors.pth
        for name in a.namelist():
            b.writestr("tensors.pth" if name == "pytorch_variables.pth" else name, a.read(name))
    new, old = read_sb3_archive(src, "sac"), read_sb3_archive(path, "sac")
    assert float(old.policy_state["log_alpha"]) == float(new.policy_state["log_alpha"])


def test_gsde_sac_plays_its_clipped_mean_as_sb3(tmp_path):
    sb3 = pytest.importorskip("stable_baselines3")
    torch.manual_seed(0)
    model = sb3.SAC("MlpPolicy", "Pendulum-v1", use_sde=True, seed=0, device="cpu",
                    policy_kwargs={"net_arch": [16], "log_std_init": -2})
    with torch.no_grad():  # a mean beyond SB3's clip_mean (2) for some observations: the clip must be kept
        model.actor.mu[0].weight.mul_(40.0)
    model.save(tmp_path / "sde")
    obs = np.stack([gym.make("Pendulum-v1").reset(seed=s)[0] for s in range(64)]).astype(np.float32)
    latent = model.actor.latent_pi(torch.as_tensor(obs))
    assert model.actor.mu[0](latent).abs().max() > 2.5
    expected, _ = model.predict(obs, deterministic=True)
    loaded = rlchain.SAC.load(str(tmp_path / "sde.zip"))
    actions, _ = loaded.predict(obs, deterministic=True)
    np.testing.assert_allclose(actions, expected, atol=1e-5)
    assert episode_return(loaded, "Pendulum-v1", 3) == pytest.approx(episode_return(model, "Pendulum-v1", 3),
                                                                     abs=1e-2)
    ppo = _rewrite_data(os.path.join(DATA, "ppo_pendulum.zip"), str(tmp_path / "ppo_sde.zip"),
                        lambda data: {**data, "use_sde": True})
    with pytest.raises(CheckpointError, match=r"ppo_sde.zip: a PPO trained with use_sde; rlchain reads gSDE"):
        rlchain.PPO.load(ppo)
