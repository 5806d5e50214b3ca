"""Atari: envpool (the shipped ppo_pong_envpool.yaml) and gymnasium + ale-py (rlchain/envs/backends/atari.py).

Covers train -> save -> play -> resume -> ONNX export of the shipped config, episodic life (a lost
life ends a training episode, the game goes on), scores counted over whole games with the
unclipped reward in training statistics and in the Player, and rl_games' resnet_actor_critic configs
with the previous reward and action as inputs (use_dict_obs_space / wrap_impala).
"""

import glob
import os
import re

import gymnasium as gym
import numpy as np
import pytest
import torch

from rlchain import Runner, env_configurations
from rlchain.cli import main as cli_main
from rlchain.config.errors import ConfigError
from rlchain.envs.factory import make_vec_env
from rlchain.envs.vecenv import StepResult
from tests.conftest import CONFIGS, ROOT

pytestmark = pytest.mark.smoke
PONG = os.path.join(CONFIGS, "ppo_pong_envpool.yaml")
RL_GAMES = os.path.join(ROOT, "benchmarks", "rl_games_configs")
SMALL = ["params.config.num_actors=4", "params.config.horizon_length=16", "params.config.minibatch_size=64",
         "params.config.print_stats=false", "params.torch_threads=1"]
"""The shipped config with fewer envs and a shorter horizon, so two epochs take seconds."""


def random_steps(env, steps, seed=0):
    """Yield StepResults of uniformly random actions."""
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        yield env.step(rng.integers(0, env.action_space.n, size=env.num_envs))


# ----- envpool: the shipped config ---------------------------------------------------------------

@pytest.mark.timeout(600)
def test_shipped_pong_envpool_train_play_resume_export(tmp_path, capsys):
    """In this process, not through ``python runner.py`` (test_train_play_resume runs the CLI's --train and
    --export): a command's child would import envpool again, about 4 s of CPU each."""
    pytest.importorskip("envpool")
    pytest.importorskip("onnxruntime")
    runs = tmp_path / "runs"
    Runner().load(PONG, ["params.config.max_epochs=2", f"params.config.train_dir={runs}", *SMALL]).train()
    last = glob.glob(str(runs / "Pong-v5_envpool_*" / "nn" / "last_Pong-v5_envpool.pth"))
    assert len(last) == 1
    last = last[0]
    saved = torch.load(last, weights_only=False)
    assert saved["epoch"] == 2 and saved["frames"] == 2 * 4 * 16
    assert saved["model"]["running_mean_std.running_mean"].shape == (4, 84, 84)

    played = Runner().load(PONG).play(last, games=1, quiet=True)
    assert played.games == 1
    assert -21 <= played.mean_reward <= 21 and played.mean_reward == int(played.mean_reward)  # a real Pong score
    assert played.mean_length > 100  # a whole game (21 points to someone), not a rally

    resumed = Runner().load(PONG, ["params.config.max_epochs=3", f"params.config.train_dir={runs}", *SMALL])
    result = resumed.train(checkpoint=last)
    assert result.epoch == 3 and result.frames == 3 * 4 * 16

    onnx_path = tmp_path / "pong.onnx"
    capsys.readouterr()
    assert cli_main(["--export", "onnx", "--file", PONG, "--checkpoint", last, "-o", str(onnx_path)]) == 0
    exported = capsys.readouterr().out
    diffs = [float(d) for d in re.findall(r"(\d\.\d+e[-+]\d+) on", exported)]
    assert len(diffs) == 2 and max(diffs) <= 1e-4, exported
    import onnxruntime as ort

    session = ort.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    graph_input = session.get_inputs()[0]
    assert graph_input.type == "tensor(uint8)" and graph_input.shape[1:] == [4, 84, 84]


def test_envpool_episodic_life_goes_on_and_reports_the_whole_game():
    pytest.importorskip("envpool")
    env = make_vec_env("envpool", {"env_name": "Breakout-v5", "episodic_life": True, "reward_clip": True,
                                   "has_lives": True}, 2, 3, None)
    try:
        assert env.observation_space.shape == (4, 84, 84) and env.observation_space.dtype == np.uint8
        env.reset()
        lives_at_end, lives_after = [], []
        for result in random_steps(env, 3000):
            if lives_at_end and len(lives_after) < len(lives_at_end):
                lives_after.append(int(result.infos["lives"][0]))  # the step after the lost life
            if result.terminated[0]:
                lives_at_end.append(int(result.infos["lives"][0]))
                if result.game_over[0]:
                    break
            else:
                assert not result.game_over[0]
        assert lives_at_end == [4, 3, 2, 1, 0]  # one training episode per life, one game
        assert lives_after[:4] == [4, 3, 2, 1]  # the reset after a lost life did not restart the game
    finally:
        env.close()


def test_envpool_game_reward_is_unclipped():
    pytest.importorskip("envpool")
    env = make_vec_env("envpool", {"env_name": "SpaceInvaders-v5", "reward_clip": True}, 2, 0, None)
    try:
        env.reset()
        clipped, raw = [], []
        for result in random_steps(env, 300):
            clipped.append(result.reward)
            raw.append(result.game_reward)
        clipped, raw = np.concatenate(clipped), np.concatenate(raw)
        assert np.abs(clipped).max() <= 1.0 and raw.max() >= 5.0  # aliens are worth 5..30 points
        assert np.array_equal(np.sign(raw), clipped)
    finally:
        env.close()


# ----- whole-game scores in the trainer and the Player (a fake env with lives) ------------------

class LivesEnv:
    """3 lives of 2 steps each: ``terminated`` every 2 steps, the game over every 6; reward 1 (clipped),
    game reward 3 per step, so every game scores 18 in 6 steps."""

    def __init__(self, num_envs, seed=None):
        self.num_envs = num_envs
        self.observation_space = gym.spaces.Box(-1, 1, (4,), np.float32)
        self.action_space = gym.spaces.Discrete(2)
        self.t = np.zeros(num_envs, dtype=np.int64)

    def reset(self, seed=None):
        self.t[:] = 0
        return np.zeros((self.num_envs, 4), np.float32)

    def step(self, actions):
        self.t += 1
        terminated = self.t % 2 == 0
        game_over = self.t % 6 == 0
        obs = np.zeros((self.num_envs, 4), np.float32)
        return StepResult(obs, np.ones(self.num_envs, np.float32), terminated, np.zeros(self.num_envs, bool),
                          obs.copy(), {}, np.full(self.num_envs, 3.0, np.float32), game_over)

    def close(self):
        pass


@pytest.fixture
def lives_env():
    build = lambda num_envs, seed, **kw: LivesEnv(num_envs, seed)  # noqa: E731
    env_configurations.register("test_lives_env", {"vecenv_creator": build}, overwrite=True)
    yield "test_lives_env"


def test_training_statistics_and_player_count_whole_games(tmp_path, lives_env, base_config):
    cfg = base_config
    cfg["params"]["config"].update(env_name=lives_env, num_actors=2, horizon_length=12, minibatch_size=8,
                                   max_epochs=2, train_dir=str(tmp_path), print_stats=False)
    result = Runner().load(cfg).train()
    assert result.mean_reward == 18.0  # 6 steps x game reward 3 over 3 lives; per life it would be 2
    last = glob.glob(os.path.join(result.run_dir, "nn", "last_*.pth"))[0]
    played = Runner().load(cfg).play(last, games=3, quiet=True)
    assert played.games == 3 and played.rewards == [18.0] * 3 and played.mean_length == 6


# ----- gymnasium + ale-py --------------------------------------------------------------------------

def atari_env(num_envs=2, seed=0, **config):
    pytest.importorskip("ale_py")
    pytest.importorskip("cv2")
    return make_vec_env("atari_gym", {"name": "BreakoutNoFrameskip-v4", **config}, num_envs, seed, None)


def test_atari_gym_observations_channels_last_by_default_and_first_on_request():
    env = atari_env()
    try:
        assert env.observation_space.shape == (84, 84, 4) and env.observation_space.dtype == np.uint8
        obs = env.reset()
        assert obs.shape == (2, 84, 84, 4) and obs.dtype == np.uint8
        result = env.step(np.zeros(2, dtype=np.int64))
        assert result.obs.shape == (2, 84, 84, 4) and result.obs.dtype == np.uint8
    finally:
        env.close()
    env = atari_env(channels_first=True, frame_stack=2)
    try:
        assert env.observation_space.shape == (2, 84, 84)
        obs = env.reset()
        assert obs.shape == (2, 2, 84, 84)
        # the stack holds consecutive frames: after a step the newest frame moved one slot back
        result = env.step(np.full(2, 3, dtype=np.int64))
        assert np.array_equal(result.obs[:, 0], obs[:, 1])
    finally:
        env.close()


def test_atari_gym_episodic_life_and_whole_game_scores():
    env = atari_env(episode_life=True, clip_rewards=True)
    try:
        env.reset()
        lives_lost, score, raw_sum = 0, 0.0, 0.0
        for result in random_steps(env, 4000, seed=1):
            raw_sum += float(result.game_reward[0])
            assert abs(float(result.reward[0])) <= 1.0
            if result.terminated[0]:
                lives_lost += 1
                if result.game_over[0]:
                    score = raw_sum
                    break
        assert lives_lost == 5  # Breakout: 5 lives, one training episode each, then the game is over
        assert score >= 0.0
    finally:
        env.close()
    env = atari_env(episode_life=False)
    try:
        env.reset()
        for result in random_steps(env, 4000, seed=1):
            if result.terminated[0]:
                assert result.game_over[0]  # without episodic life an episode is the game
                break
        else:
            pytest.fail("no Breakout game ended in 4000 random steps")
    finally:
        env.close()


def test_atari_gym_seeding_is_reproducible():
    runs = []
    for _ in range(2):
        env = atari_env(seed=11)
        try:
            obs = [env.reset()]
            obs += [result.obs for result in random_steps(env, 40, seed=2)]
            runs.append(np.stack(obs))
        finally:
            env.close()
    assert np.array_equal(runs[0], runs[1])


@pytest.mark.parametrize("config,vecenv_type,pattern", [
    ({}, None, r"env_config\.name: is required"),
    ({"name": "PongNoFrameskip-v4", "episodic_life": True}, None, r"env_config\.episodic_life: .*did you mean "
                                                                   r"'episode_life'"),
    ({"name": "PongNoFrameskip-v4"}, "native", r"vecenv_type: 'native' does not apply"),
])
def test_atari_gym_config_errors(config, vecenv_type, pattern):
    with pytest.raises(ConfigError, match=pattern):
        make_vec_env("atari_gym", config, 1, 0, vecenv_type)


@pytest.mark.timeout(600)
@pytest.mark.parametrize("name", ["ppo_breakout.yaml", "ppo_pong.yaml"])
def test_rl_games_atari_gym_configs_train_and_play_unchanged(tmp_path, name):
    """rl_games' configs/atari/ppo_breakout.yaml (env_name atari_gym) and ppo_pong.yaml (the
    PongNoFrameskip-v4 preset), device cpu, fewer envs: two epochs, a checkpoint, one game."""
    pytest.importorskip("ale_py")
    pytest.importorskip("cv2")
    path = os.path.join(RL_GAMES, name)
    overrides = ["params.config.max_epochs=2", f"params.config.train_dir={tmp_path}", "params.torch_threads=1",
                 "params.config.num_actors=4", "params.config.horizon_length=16", "params.config.minibatch_size=32",
                 "params.config.print_stats=false"]
    result = Runner().load(path, overrides).train()
    assert result.epoch == 2 and result.frames == 2 * 4 * 16
    run_name = Runner().load(path).params.config.name
    last = os.path.join(result.run_dir, "nn", f"last_{run_name}.pth")
    assert os.path.isfile(last)
    if name == "ppo_breakout.yaml":  # a Breakout game of an untrained policy is short (5 lost lives)
        # one torch thread as in training (the config's torch_threads 4 would be 2 on 2 cores: several times the
        # CPU of one thread for a batch of one image on a busy machine)
        played = Runner().load(path, ["params.config.player.render=false", "params.torch_threads=1"]).play(
            last, games=1, quiet=True)
        assert played.games == 1 and played.mean_length > 5 * 10


def test_cnn_policy_on_uint8_images_trains_one_epoch(tmp_path, base_config):
    """A tiny CNN on the gymnasium Atari env, channels-first: the generic (non-rl_games) path."""
    pytest.importorskip("ale_py")
    pytest.importorskip("cv2")
    cfg = base_config
    cfg["params"]["network"]["cnn"] = {"type": "conv2d", "permute_input": False, "activation": "relu",
                                       "convs": [{"filters": 4, "kernel_size": 8, "strides": 4},
                                                 {"filters": 8, "kernel_size": 4, "strides": 2}]}
    cfg["params"]["config"].update(env_name="atari_gym", env_config={"name": "ALE/Pong-v5", "channels_first": True},
                                   num_actors=2, horizon_length=16, minibatch_size=16, max_epochs=1,
                                   normalize_input=True, train_dir=str(tmp_path), print_stats=False)
    runner = Runner().load(cfg)
    result = runner.train()
    assert result.epoch == 1 and result.frames == 32
    state = torch.load(os.path.join(result.run_dir, "nn", "last_t.pth"), weights_only=False)
    mean = state["model"]["running_mean_std.running_mean"]
    assert mean.shape == (4, 84, 84) and 0.0 <= float(mean.min()) and float(mean.max()) <= 1.0


# ----- rl_games' previous reward / action observations (use_dict_obs_space, wrap_impala) ------------

def test_atari_gym_wrap_impala_observations():
    env = atari_env(wrap_impala=True)
    try:
        layout = env.observation_space.dict_space
        assert list(layout.spaces) == ["last_action", "observation", "reward"]
        assert layout["observation"].shape == (84, 84, 4) and layout["last_action"].n == 4
        obs = env.reset()
        assert obs.shape == (2, 4 + 84 * 84 * 4 + 1) and obs.dtype == np.float32 and 0 <= obs.min() <= obs.max() <= 1
        result = env.step(np.array([1, 3]))
        assert list(result.obs[:, :4].argmax(1)) == [1, 3]
    finally:
        env.close()


def test_use_dict_obs_space_needs_discrete_actions():
    pytest.importorskip("envpool")
    with pytest.raises(ConfigError, match=r"env_config\.use_dict_obs_space: needs Discrete actions"):
        make_vec_env("envpool", {"env_name": "Pendulum-v1", "use_dict_obs_space": True}, 2, 0, None)


# ----- resnet_actor_critic with the previous reward and action (rl_games' resnet configs) ----------

RESNET_SMALL = ["params.config.num_actors=4", "params.config.horizon_length=16", "params.config.minibatch_size=32",
                "params.config.print_stats=false", "params.torch_threads=1", "params.config.player.render=false"]


@pytest.mark.timeout(600)
def test_rl_games_pong_envpool_resnet_trains_plays_and_resumes(tmp_path):
    """rl_games' atari/ppo_pong_envpool_resnet.yaml (IMPALA + LSTM, require_rewards / require_last_actions,
    use_dict_obs_space) with 4 envs in 2 pipelined groups: an epoch, one game from the checkpoint, a resume.

    The game is cut at 60 steps by envpool's time limit (``player.env_config``: the player's env only), which ends
    it as any game end does; that a played Pong game through envpool is the whole game (21 points, hundreds of
    steps) is test_shipped_pong_envpool_train_play_resume_export's, on the same backend."""
    pytest.importorskip("envpool")
    path = os.path.join(RL_GAMES, "ppo_pong_envpool_resnet.yaml")
    small = [*RESNET_SMALL, f"params.config.train_dir={tmp_path}", "params.config.env_groups=2"]
    result = Runner().load(path, ["params.config.max_epochs=1", *small]).train()
    assert result.epoch == 1 and result.frames == 4 * 16
    last = os.path.join(result.run_dir, "nn", "last_Pong-v5_envpool_resnet.pth")
    saved = torch.load(last, weights_only=False)
    lstm = saved["model"]["a2c_network.rnn.rnn.weight_ih_l0"]
    assert lstm.shape == (4 * 256, 512 + 1 + 6)  # mlp features + reward + one-hot of Pong's 6 actions

    cut = ["params.config.player.env_config={max_episode_steps: 60}"]
    played = Runner().load(path, [*small, *cut]).play(last, games=1, quiet=True)
    assert played.games == 1 and played.mean_length == 60 and -21 <= played.mean_reward <= 21

    resumed = Runner().load(path, ["params.config.max_epochs=2", *small]).train(checkpoint=last)
    assert resumed.epoch == 2 and resumed.frames == 2 * 4 * 16


@pytest.mark.timeout(600)
def test_rl_games_breakout_torch_impala_trains_and_plays(tmp_path):
    """rl_games' atari/ppo_breakout_torch_impala.yaml: atari_gym with wrap_impala, channels-last frames."""
    pytest.importorskip("ale_py")
    pytest.importorskip("cv2")
    path = os.path.join(RL_GAMES, "ppo_breakout_torch_impala.yaml")
    small = [*RESNET_SMALL, f"params.config.train_dir={tmp_path}", "params.config.num_actors=2"]
    result = Runner().load(path, ["params.config.max_epochs=1", *small]).train()
    assert result.epoch == 1 and result.frames == 2 * 16
    last = os.path.join(result.run_dir, "nn", "last_breakout_impala_lstm.pth")
    played = Runner().load(path, small).play(last, games=1, quiet=True)
    assert played.games == 1 and played.mean_length > 5 * 10  # 5 lives lost: a whole game
