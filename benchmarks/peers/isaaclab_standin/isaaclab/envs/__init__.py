"""The env base classes the rl_games wrapper checks for, and a batched torch cart-pole written on them."""

from dataclasses import dataclass, field

import gymnasium as gym
import numpy as np
import torch

VecEnvObs = dict


@dataclass
class SceneCfg:
    num_envs: int = 64


@dataclass
class SimCfg:
    device: str = "cpu"
    dt: float = 0.02


@dataclass
class DirectRLEnvCfg:
    scene: SceneCfg = field(default_factory=SceneCfg)
    sim: SimCfg = field(default_factory=SimCfg)
    seed: int | None = None
    is_finite_horizon: bool = False
    episode_length_s: float = 5.0

    def to_dict(self) -> dict:
        return {"num_envs": self.scene.num_envs, "device": self.sim.device, "seed": self.seed}


ManagerBasedRLEnvCfg = DirectRLEnvCfg


class DirectRLEnv(gym.Env):
    """Batched envs on ``cfg.sim.device`` with observation groups, as Isaac Lab's direct workflow."""

    def __init__(self, cfg: DirectRLEnvCfg, render_mode: str | None = None, **kwargs) -> None:
        self.cfg = cfg
        self.render_mode = render_mode
        self.num_envs = cfg.scene.num_envs
        self.device = cfg.sim.device
        self.step_dt = cfg.sim.dt
        self.max_episode_length = int(cfg.episode_length_s / cfg.sim.dt)

    def seed(self, seed: int = -1) -> int:
        torch.manual_seed(seed)
        return seed


class ManagerBasedRLEnv(DirectRLEnv):
    pass


class CartpoleStandinEnv(DirectRLEnv):
    """Cart-poles pushed by a force in [-1, 1] (times 10 N): +1 per step upright, episodes end when the pole
    falls past 12 degrees or the cart leaves [-2.4, 2.4], or time out after ``episode_length_s``."""

    def __init__(self, cfg: DirectRLEnvCfg, render_mode: str | None = None, **kwargs) -> None:
        super().__init__(cfg, render_mode)
        box = gym.spaces.Box(-np.inf, np.inf, (4,), np.float32)
        self.single_observation_space = gym.spaces.Dict({"policy": box})
        self.single_action_space = gym.spaces.Box(-np.inf, np.inf, (1,), np.float32)
        self.gen = torch.Generator(device=self.device).manual_seed(cfg.seed or 0)
        self.state = torch.zeros(self.num_envs, 4, device=self.device)
        self.length = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self.returns = torch.zeros(self.num_envs, device=self.device)
        self.finished: list[float] = []  # returns of the episodes that ended, printed at close

    @property
    def unwrapped(self):
        return self

    def _reset_rows(self, rows: torch.Tensor) -> None:
        n = int(rows.sum())
        self.state[rows] = (torch.rand(n, 4, generator=self.gen, device=self.device) - 0.5) * 0.1
        self.length[rows] = 0
        self.returns[rows] = 0.0

    def _observations(self) -> dict:
        return {"policy": self.state.clone()}

    def reset(self, seed: int | None = None, options: dict | None = None):
        self._reset_rows(torch.ones(self.num_envs, dtype=torch.bool, device=self.device))
        return self._observations(), {}

    def step(self, actions: torch.Tensor):
        x, x_dot, theta, theta_dot = self.state.unbind(1)
        force = actions[:, 0].clamp(-1.0, 1.0) * 10.0
        cos, sin = torch.cos(theta), torch.sin(theta)
        temp = (force + 0.05 * theta_dot**2 * sin) / 1.1
        theta_acc = (9.8 * sin - cos * temp) / (0.5 * (4.0 / 3.0 - 0.1 * cos**2 / 1.1))
        x_acc = temp - 0.05 * theta_acc * cos / 1.1
        dt = self.step_dt
        self.state = torch.stack([x + dt * x_dot, x_dot + dt * x_acc, theta + dt * theta_dot,
                                  theta_dot + dt * theta_acc], 1)
        self.length += 1
        terminated = (self.state[:, 0].abs() > 2.4) | (self.state[:, 2].abs() > 0.2095)
        truncated = (self.length >= self.max_episode_length) & ~terminated
        reward = torch.ones(self.num_envs, device=self.device)
        self.returns += reward
        done = terminated | truncated
        extras = {}
        if done.any():
            extras["log"] = {"Episode_Reward/alive": self.returns[done].mean(),
                             "Episode_Termination/time_out": truncated[done].float().mean()}
            self.finished += self.returns[done].tolist()
            self._reset_rows(done)
        return self._observations(), reward, terminated, truncated, extras

    def close(self) -> None:
        if self.finished:
            print(f"[stand-in] {len(self.finished)} episodes ended, mean return "
                  f"{sum(self.finished) / len(self.finished):.1f}")


class CartpoleAsymStandinEnv(CartpoleStandinEnv):
    """The cart-pole with a privileged ``critic`` group beside ``policy``, as Isaac Lab's asymmetric tasks:
    the critic also sees the fraction of the episode's time limit used (5 values against the policy's 4),
    so Isaac Lab's wrapper hands rl_games ``{"obs", "states"}`` and a ``state_space``."""

    def __init__(self, cfg: DirectRLEnvCfg, render_mode: str | None = None, **kwargs) -> None:
        super().__init__(cfg, render_mode)
        self.single_observation_space = gym.spaces.Dict({
            "policy": gym.spaces.Box(-np.inf, np.inf, (4,), np.float32),
            "critic": gym.spaces.Box(-np.inf, np.inf, (5,), np.float32)})

    def _observations(self) -> dict:
        progress = (self.length.float() / self.max_episode_length).unsqueeze(1)
        return {"policy": self.state.clone(), "critic": torch.cat([self.state, progress], 1)}
