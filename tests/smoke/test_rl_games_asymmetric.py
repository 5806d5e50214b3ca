"""The asymmetric path as Isaac Lab's rl_games wrapper drives it: an IVecEnv whose ``get_env_info`` has a
``state_space`` (OpenAI gym spaces) and whose observations are ``{"obs", "states"}``, with the agent config's
``central_value_config`` written as Isaac Lab's asymmetric tasks write it. Through rl_games' Python API the
central value trains on ``states`` and the actor on ``obs``; the player acts on ``obs`` alone, rl_games' play
loop on the dicts; a resume brings the central value back."""

import copy

import numpy as np
import pytest
import torch

from rlchain.runs.checkpoint import load as load_checkpoint

gym = pytest.importorskip("gym")  # OpenAI gym 0.26, what Isaac Lab's rl-games extra installs

pytestmark = pytest.mark.smoke

NUM_ENVS, OBS, STATE = 32, 3, 5
MARK = 7.0  # the last state column: only the central value's input statistics can see it


class CriticGroupEnv:
    """Batched torch envs: the actor sees a noisy 3-d view, the critic the true 4-d state plus MARK."""

    def __init__(self) -> None:
        self.gen = torch.Generator().manual_seed(0)
        self.pos = torch.zeros(NUM_ENVS, 4)
        self.steps = torch.zeros(NUM_ENVS, dtype=torch.long)

    def get_env_info(self) -> dict:
        box = gym.spaces.Box
        return {"observation_space": box(-5.0, 5.0, (OBS,), np.float32),
                "action_space": box(-1.0, 1.0, (1,), np.float32),
                "state_space": box(-10.0, 10.0, (STATE,), np.float32)}

    def get_number_of_agents(self) -> int:
        return 1

    def _obs(self) -> dict:
        view = self.pos[:, :OBS] + 0.01 * torch.randn(NUM_ENVS, OBS, generator=self.gen)
        return {"obs": view, "states": torch.cat([self.pos, torch.full((NUM_ENVS, 1), MARK)], 1)}

    def reset(self) -> dict:
        self.pos = torch.rand(NUM_ENVS, 4, generator=self.gen) - 0.5
        return self._obs()

    def step(self, actions: torch.Tensor):
        self.pos = self.pos + 0.1 * actions.clamp(-1, 1)
        self.steps += 1
        rewards = -self.pos.abs().sum(1)
        dones = self.steps >= 20
        if dones.any():
            self.pos[dones] = torch.rand(int(dones.sum()), 4, generator=self.gen) - 0.5
            self.steps[dones] = 0
        return self._obs(), rewards, dones, {"time_outs": dones.clone()}


CONFIG = {"params": {
    "seed": 3,
    "algo": {"name": "a2c_continuous"},
    "model": {"name": "continuous_a2c_logstd"},
    "network": {"name": "actor_critic", "separate": False,
                "space": {"continuous": {"mu_activation": "None", "sigma_activation": "None",
                                         "mu_init": {"name": "default"}, "fixed_sigma": True,
                                         "sigma_init": {"name": "const_initializer", "val": 0}}},
                "mlp": {"units": [16], "activation": "elu", "initializer": {"name": "default"}}},
    "config": {
        "name": "asym", "env_name": "rlgpu", "device": "cpu", "num_actors": NUM_ENVS, "horizon_length": 16,
        "minibatch_size": 256, "mini_epochs": 2, "learning_rate": 3e-4, "lr_schedule": "adaptive",
        "kl_threshold": 0.008, "normalize_input": True, "normalize_value": True, "value_bootstrap": True,
        "gamma": 0.99, "tau": 0.95, "e_clip": 0.2, "critic_coef": 4, "entropy_coef": 0.0, "max_epochs": 2,
        "save_frequency": 1, "print_stats": False,
        # Isaac Lab's asymmetric tasks write the central value's block this way: schedule_type and
        # kl_threshold rl_games never reads there, and 'adaptive' it reads as a constant rate
        "central_value_config": {
            "minibatch_size": 256, "mini_epochs": 2, "learning_rate": 5e-4, "lr_schedule": "adaptive",
            "schedule_type": "standard", "kl_threshold": 0.008, "clip_value": True, "normalize_input": True,
            "truncate_grads": True,
            "network": {"name": "actor_critic", "central_value": True,
                        "mlp": {"units": [24], "activation": "elu", "initializer": {"name": "default"}}}}},
}}


@pytest.fixture
def rlgpu(scoped_registries):
    """rlgpu registered as Isaac Lab's train.py registers it: one env object, an IVecEnv around it."""
    from rlchain.rl_games.common import env_configurations, vecenv

    env = CriticGroupEnv()

    class Wrapper(vecenv.IVecEnv):
        def __init__(self, config_name, num_actors, **kwargs):
            self.env = env_configurations.configurations[config_name]["env_creator"](**kwargs)

        def step(self, actions):
            return self.env.step(actions)

        def reset(self):
            return self.env.reset()

        def get_number_of_agents(self):
            return self.env.get_number_of_agents()

        def get_env_info(self):
            return self.env.get_env_info()

    vecenv.register("IsaacRlgWrapper", lambda name, n, **kw: Wrapper(name, n, **kw))
    env_configurations.register("rlgpu", {"vecenv_type": "IsaacRlgWrapper", "env_creator": lambda **kw: env})
    return env


def test_the_central_value_trains_on_states_plays_on_obs_and_resumes(tmp_path, rlgpu):
    from rlchain.rl_games.torch_runner import Runner

    cfg = copy.deepcopy(CONFIG)
    cfg["params"]["config"]["train_dir"] = str(tmp_path)
    runner = Runner()
    with pytest.warns(Warning) as caught:
        runner.load(cfg)
    said = " ".join(str(w.message) for w in caught)
    assert "central_value_config.schedule_type" in said and "central_value_config.kl_threshold" in said
    assert "central_value_config.lr_schedule: 'adaptive' read as a constant" in said
    first = runner.run({"train": True})
    assert first.epoch == 2

    last = sorted(tmp_path.glob("*/nn/last_asym_ep_2_rew__*_.pth"))[-1]
    state = load_checkpoint(str(last))
    actor_in = state["model"]["a2c_network.actor_mlp.0.weight"].shape[1]
    critic_in = state["central_value"]["a2c_network.actor_mlp.0.weight"].shape[1]
    assert (actor_in, critic_in) == (OBS, STATE)
    # only the critic's inputs carry MARK: its normalizer saw `states`, the actor's saw `obs`
    assert state["central_value"]["running_mean_std.running_mean"][-1].item() == pytest.approx(MARK, abs=1e-3)
    assert state["model"]["running_mean_std.running_mean"].shape == (OBS,)

    player = runner.create_player()  # what Isaac Lab's play.py does: actions from obs["obs"] alone
    player.restore(str(last))
    player.reset()
    obs = rlgpu.reset()["obs"]
    player.get_batch_size(obs, 1)
    actions = player.get_action(player.obs_to_torch(obs), is_deterministic=True)
    assert actions.shape == (NUM_ENVS, 1) and torch.isfinite(actions).all()

    cfg["params"]["config"]["player"] = {"use_vecenv": True, "num_actors": NUM_ENVS, "games_num": 4}
    runner.load(cfg)  # rl_games' own play loop on the same env: it takes the {"obs", "states"} dicts
    played = runner.run({"train": False, "play": True, "checkpoint": str(last)})
    assert played.games == 4

    cfg["params"]["config"]["max_epochs"] = 3
    runner.load(cfg)
    resumed = runner.run({"train": True, "checkpoint": str(last)})
    assert resumed.epoch == 3
    again = load_checkpoint(str(sorted(tmp_path.glob("*/nn/last_asym_ep_3_rew__*_.pth"))[-1]))
    assert again["epoch"] == 3
    assert again["central_value"]["running_mean_std.running_mean"][-1].item() == pytest.approx(MARK)
