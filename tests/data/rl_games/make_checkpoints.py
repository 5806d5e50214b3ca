"""Writes the small rl_games checkpoints in this folder with the real rl_games (not rlchain).

Run it with rl_games installed, once per version, e.g. from a venv with ``torch==2.13.0``,
``rl_games==1.6.5`` and ``gym==0.26.2``:

    python tests/data/rl_games/make_checkpoints.py --tag v165
    PYTHONPATH=<rl_games main checkout> python tests/data/rl_games/make_checkpoints.py --tag v20

Each run trains two epochs of PPO, continuous (``a2c_continuous``) and discrete (``a2c_discrete``) with an
8-unit MLP, and continuous with separate actor and critic MLPs of two 8-unit layers, all with input and value
normalization; PPO with an LSTM after the MLP (``lstm``), separate GRUs before the MLPs with a LayerNorm on
their output (``gru_separate``), a conv2d encoder over channels-last images (``cnn``), rl_games' IMPALA
``resnet_actor_critic`` with an LSTM (``resnet_lstm``, discrete), the network-level
``normalization: layer_norm`` (``layer_norm``; rl_games 1.6.5 builds no MLP norm layers for it, 2.0 does), an
asymmetric critic (``central_value_config``) on the env's states (``central_value``), a Tuple of two Discrete
actions (``multi_discrete``);
and four epochs of SAC without and with that normalization (``sac``, ``sac_layer_norm``). The env is a tiny
batched torch env that reports OpenAI gym spaces (as Isaac Lab's wrapper does). Each run keeps rl_games' last
checkpoint as ``<tag>_<kind>.pth`` and the deterministic actions rl_games' player takes with it as
``<tag>_<kind>_actions.pt`` (three steps in a row from zero states for the recurrent kinds: ``actions`` is
(steps, batch, ...)). ``--kinds`` picks some. Real rl_games 1.6.5 and 2.0 wrote the files here.
``tests/unit/test_rl_games_checkpoint.py`` reads them with the same config (:data:`CONFIGS`).
"""

from __future__ import annotations

import argparse
import copy
import glob
import os
import shutil
import tempfile

import numpy as np
import torch

OBS, ACTIONS, HORIZON = 3, 2, 16
STATE = 6  # the central_value kind's critic input: the point and its square
IMAGE = (6, 6, 2)  # the cnn kind's channels-last observations: the env's point tiled over the image
RNN_STEPS = 3


def is_continuous(kind: str) -> bool:
    return kind not in ("discrete", "cnn", "multi_discrete", "resnet_lstm")


MULTI = (2, 3)  # the multi_discrete kind's actions: rl_games' Tuple of Discrete


def config(kind: str) -> dict:
    """The rl_games config of ``kind`` these checkpoints were trained with: continuous, discrete, or
    separate (continuous, separate actor and critic MLPs of two layers), lstm, gru_separate, cnn, layer_norm,
    sac."""
    if kind.startswith("sac"):
        return sac_config(kind)
    continuous = is_continuous(kind)
    space = ({"continuous": {"mu_activation": "None", "sigma_activation": "None", "mu_init": {"name": "default"},
                             "sigma_init": {"name": "const_initializer", "val": 0}, "fixed_sigma": True}}
             if continuous else {"multi_discrete": {}} if kind == "multi_discrete" else {"discrete": {}})
    network = {"name": "actor_critic", "separate": kind in ("separate", "gru_separate"), "space": space,
               "mlp": {"units": [8, 8] if kind in ("separate", "layer_norm") else [8], "activation": "elu",
                       "initializer": {"name": "default"}}}
    if kind == "lstm":
        network["rnn"] = {"name": "lstm", "units": 8, "layers": 1}
    if kind == "gru_separate":
        network["rnn"] = {"name": "gru", "units": 8, "layers": 1, "before_mlp": True, "layer_norm": True}
    if kind == "cnn":
        network["cnn"] = {"type": "conv2d", "activation": "relu", "initializer": {"name": "default"},
                          "convs": [{"filters": 4, "kernel_size": 3, "strides": 1, "padding": 0},
                                    {"filters": 4, "kernel_size": 2, "strides": 2, "padding": 0}]}
    if kind == "layer_norm":
        network["normalization"] = "layer_norm"
    if kind == "resnet_lstm":  # rl_games' IMPALA network (its Atari configs), with an LSTM after the MLP
        network = {"name": "resnet_actor_critic", "separate": False, "space": space, "value_activation": "None",
                   "cnn": {"permute_input": True, "conv_depths": [2, 2], "activation": "relu",
                           "initializer": {"name": "default"}},
                   "mlp": {"units": [8], "activation": "elu", "initializer": {"name": "default"}},
                   "rnn": {"name": "lstm", "units": 8, "layers": 1}}
    extra = {}
    if kind == "central_value":  # an asymmetric critic on the env's states, as Isaac Lab's and IsaacGymEnvs' do
        extra["central_value_config"] = {
            "minibatch_size": 16, "mini_epochs": 1, "learning_rate": 3e-4, "clip_value": True,
            "normalize_input": True, "truncate_grads": True, "grad_norm": 1.0,
            "network": {"name": "actor_critic", "central_value": True,
                        "mlp": {"units": [8], "activation": "elu", "initializer": {"name": "default"}}}}
    return {"params": {
        "seed": 3,
        "algo": {"name": "a2c_continuous" if continuous else "a2c_discrete"},
        "model": {"name": "continuous_a2c_logstd" if continuous else
                  "multi_discrete_a2c" if kind == "multi_discrete" else "discrete_a2c"},
        "network": network,
        "config": {"name": f"tiny_{kind}", "env_name": "tiny_env", "device": "cpu", "device_name": "cpu", "ppo": True,
                   "normalize_input": kind not in ("cnn", "resnet_lstm"), "normalize_value": True,
                   "normalize_advantage": True,
                   "reward_shaper": {"scale_value": 1.0}, "num_actors": 4, "horizon_length": 8,
                   "minibatch_size": 16, "mini_epochs": 1, "learning_rate": 3e-4, "lr_schedule": None,
                   "gamma": 0.99, "tau": 0.95, "e_clip": 0.2, "entropy_coef": 0.0, "critic_coef": 2,
                   "clip_value": True, "bounds_loss_coef": 0.0001, "grad_norm": 1.0, "truncate_grads": True,
                   "kl_threshold": 0.008, "max_epochs": 2, "save_frequency": 1, "save_best_after": 1,
                   "score_to_win": 10000, "seq_length": 4, "print_stats": False,
                   "player": {"games_num": 2, "deterministic": True}, **extra},
    }}


def sac_config(kind: str = "sac") -> dict:
    """rl_games' SAC (``sac`` / ``soft_actor_critic``) with 8-unit twin critics and input normalization;
    ``sac_layer_norm``: with rl_games 2.0's ``normalization: layer_norm`` (its MuJoCo SAC configs)."""
    network = {"name": "soft_actor_critic", "separate": True, "space": {"continuous": {}},
               "mlp": {"units": [8, 8], "activation": "relu", "initializer": {"name": "default"}},
               "log_std_bounds": [-5, 2]}
    if kind == "sac_layer_norm":
        network["normalization"] = "layer_norm"
    return {"params": {
        "seed": 3,
        "algo": {"name": "sac"},
        "model": {"name": "soft_actor_critic"},
        "network": network,
        "config": {"name": f"tiny_{kind}", "env_name": "tiny_env", "device": "cpu", "device_name": "cpu",
                   "normalize_input": True,
                   "reward_shaper": {"scale_value": 1.0}, "max_epochs": 4, "num_steps_per_episode": 4,
                   "save_best_after": 1, "save_frequency": 1, "gamma": 0.99, "init_alpha": 1.0,
                   "alpha_lr": 3e-4, "actor_lr": 3e-4, "critic_lr": 1e-3, "critic_tau": 5e-3, "batch_size": 16,
                   "learnable_temperature": True, "num_warmup_steps": 2, "replay_buffer_size": 256,
                   "num_actors": 4, "print_stats": False, "player": {"games_num": 2, "deterministic": True}},
    }}


KINDS = ("continuous", "discrete", "separate", "lstm", "gru_separate", "cnn", "resnet_lstm", "layer_norm",
         "central_value", "multi_discrete", "sac", "sac_layer_norm")
RNN_KINDS = ("lstm", "gru_separate", "resnet_lstm")
CONFIGS = {kind: config(kind) for kind in KINDS}


def obs_shape(kind: str) -> tuple[int, ...]:
    return IMAGE if kind in ("cnn", "resnet_lstm") else (OBS,)


def observe(pos: torch.Tensor, shape: tuple[int, ...]) -> torch.Tensor:
    """The env's observation of points ``pos`` (n, OBS): the points, or tiled over an image of ``shape``."""
    if len(shape) == 1:
        return pos.clone()
    size = int(np.prod(shape))
    return pos.repeat(1, -(-size // OBS))[:, :size].reshape(-1, *shape).contiguous()


def fixed_obs(kind: str) -> torch.Tensor:
    """The five observations the parity files hold the actions for."""
    return observe(torch.linspace(-1.5, 1.5, 5 * OBS).reshape(5, OBS), obs_shape(kind))


def make_env_class(kind: str):
    import gym  # OpenAI gym 0.26: the spaces Isaac Lab's rl_games wrapper returns
    from rl_games.common.ivecenv import IVecEnv

    continuous, shape = is_continuous(kind), obs_shape(kind)

    class TinyVecEnv(IVecEnv):
        """Move a point towards the origin; episodes end after HORIZON steps."""

        def __init__(self, num_envs: int) -> None:
            self.n = num_envs
            self.pos = torch.zeros(num_envs, OBS)
            self.t = torch.zeros(num_envs, dtype=torch.long)
            self.gen = torch.Generator().manual_seed(0)

            self.observation_space = gym.spaces.Box(-np.inf, np.inf, shape, np.float32)
            self.state_space = gym.spaces.Box(-np.inf, np.inf, (STATE,), np.float32) if kind == "central_value" \
                else None
            self.action_space = (gym.spaces.Box(-1.0, 1.0, (ACTIONS,), np.float32) if continuous
                                 else gym.spaces.Tuple([gym.spaces.Discrete(n) for n in MULTI])
                                 if kind == "multi_discrete" else gym.spaces.Discrete(ACTIONS))

        def get_env_info(self) -> dict:
            info = {"observation_space": self.observation_space, "action_space": self.action_space}
            if self.state_space is not None:
                info["state_space"] = self.state_space
            return info

        def _obs(self):
            obs = observe(self.pos, shape)
            return obs if self.state_space is None else {"obs": obs, "states": torch.cat([self.pos, self.pos ** 2], 1)}

        def get_number_of_agents(self) -> int:
            return 1

        def reset(self):
            self.pos = torch.rand(self.n, OBS, generator=self.gen) * 2 - 1
            self.t.zero_()
            return self._obs()

        def step(self, actions):
            actions = torch.as_tensor(actions)
            push = actions[:, :1] if continuous else (actions.reshape(self.n, -1)[:, :1].float() * 2 - 1)
            self.pos = self.pos - 0.1 * push.clamp(-1, 1)
            self.t += 1
            rewards = -self.pos.norm(dim=1)
            dones = self.t >= HORIZON
            if dones.any():
                self.pos[dones] = torch.rand(int(dones.sum()), OBS, generator=self.gen) * 2 - 1
                self.t[dones] = 0
            return self._obs(), rewards, dones, {"time_outs": dones.clone()}

    return TinyVecEnv


def player_actions(player, kind: str) -> torch.Tensor:
    """The deterministic actions ``player`` (rl_games' or rlchain's, restored) takes on :func:`fixed_obs`:
    (batch, ...) or, for a recurrent network, (RNN_STEPS, batch, ...) from zero states."""
    obs = fixed_obs(kind)
    player.has_batch_dimension = True
    player.get_batch_size(obs, 1)
    steps = RNN_STEPS if kind in RNN_KINDS else 1
    if kind in RNN_KINDS:
        player.init_rnn()
    out = []
    with torch.no_grad():
        for _ in range(steps):
            out.append(torch.as_tensor(player.get_action(obs, is_deterministic=True)).float().reshape(len(obs), -1))
    return torch.stack(out) if kind in RNN_KINDS else out[0]


def train(kind: str, tag: str, out_dir: str) -> str:
    from rl_games.common import env_configurations, vecenv
    from rl_games.torch_runner import Runner

    env_class = make_env_class(kind)
    vecenv.register("TINY", lambda config_name, num_actors, **kwargs: env_class(num_actors))
    env_configurations.register("tiny_env", {"vecenv_type": "TINY", "env_creator": lambda **kwargs: env_class(4)})
    cfg = copy.deepcopy(CONFIGS[kind])
    with tempfile.TemporaryDirectory() as tmp:
        cfg["params"]["config"]["train_dir"] = tmp
        cfg["params"]["config"]["full_experiment_name"] = "run"
        torch.manual_seed(0)
        runner = Runner()
        runner.load(cfg)
        runner.reset()
        runner.run({"train": True, "play": False})
        last = sorted(glob.glob(os.path.join(tmp, "run", "nn", "*.pth")), key=os.path.getmtime)[-1]
        target = os.path.join(out_dir, f"{tag}_{kind}.pth")
        shutil.copyfile(last, target)
        # the deterministic actions rl_games' own player takes with it, for the parity test
        player = runner.create_player()
        player.restore(target)
        torch.save({"obs": fixed_obs(kind), "actions": player_actions(player, kind)},
                   os.path.join(out_dir, f"{tag}_{kind}_actions.pt"))
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tag", required=True, help="file name prefix: the rl_games version (v165, v20)")
    parser.add_argument("--out", default=os.path.dirname(os.path.abspath(__file__)))
    parser.add_argument("--kinds", nargs="*", default=list(KINDS), choices=KINDS)
    args = parser.parse_args()
    for kind in args.kinds:
        print("wrote", train(kind, args.tag, args.out))


if __name__ == "__main__":
    main()
