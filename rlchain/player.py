"""Inference from a checkpoint: deterministic or stochastic play over ``games_num`` episodes."""

from __future__ import annotations

import time
from dataclasses import dataclass

import torch

from rlchain.config.schema import Params
from rlchain.training import checkpoint as ckpt
from rlchain.training.build import build_env, build_model, resolve_device


@dataclass
class PlayResult:
    """Mean episode reward and length over the games played."""

    games: int
    mean_reward: float
    mean_length: float
    rewards: list[float]


class Player:
    """Loads a checkpoint into a freshly built model and plays episodes.

    The env count comes from ``player.num_actors`` (1 by default), not from training's num_actors.
    """

    def __init__(self, params: Params, checkpoint_path: str | None, device: str | None = None,
                 sigma: float | None = None) -> None:
        self.params = params
        cfg = params.config
        self.player_cfg = cfg.player
        self.device = resolve_device(device or cfg.device)
        self.num_envs = self.player_cfg.num_actors if self.player_cfg.use_vecenv else 1
        seed = params.seed if params.seed is not None else 0
        self.env = build_env(params, self.num_envs, seed, render=self.player_cfg.render,
                             env_config=self.player_cfg.env_config)
        self.model = build_model(params, self.env, self.device)
        if checkpoint_path:
            state = ckpt.load(checkpoint_path, map_location=self.device)
            ckpt.load_model_state(self.model, state, checkpoint_path)
        if sigma is not None:
            self.model.override_sigma(sigma)
        self.model.eval()
        self.seed = seed

    def play(self, games: int | None = None, deterministic: bool | None = None,
             quiet: bool = False) -> PlayResult:
        """Play ``games`` episodes (default player.games_num) and report their mean reward/length."""
        pc = self.player_cfg
        games = games or pc.games_num
        deterministic = pc.deterministic if deterministic is None else deterministic
        dist = self.model.dist
        obs = torch.as_tensor(self.env.reset(seed=self.seed), device=self.device)
        returns = torch.zeros(self.num_envs, dtype=torch.float64)
        lengths = torch.zeros(self.num_envs, dtype=torch.long)
        rewards, episode_lengths = [], []
        while len(rewards) < games:
            actions = self.model.act(obs, deterministic=deterministic)["actions"]
            env_actions = dist.to_env(actions)
            result = self.env.step(env_actions if getattr(self.env, "is_tensor_env", False)
                                   else env_actions.cpu().numpy())
            reward = torch.as_tensor(result.reward, dtype=torch.float64).cpu()
            returns += reward.sum(-1) if reward.dim() > 1 else reward
            lengths += 1
            done = (torch.as_tensor(result.terminated) | torch.as_tensor(result.truncated)).cpu()
            for i in done.nonzero().flatten().tolist():
                if len(rewards) < games:
                    rewards.append(float(returns[i]))
                    episode_lengths.append(int(lengths[i]))
                    if pc.print_stats and not quiet:
                        print(f"game {len(rewards)}: reward {returns[i]:.2f} steps {int(lengths[i])}", flush=True)
                returns[i], lengths[i] = 0.0, 0
            if pc.render:
                self.env.render()
                time.sleep(pc.render_sleep)
            obs = torch.as_tensor(result.obs, device=self.device)
        mean_r = sum(rewards) / len(rewards)
        mean_l = sum(episode_lengths) / len(episode_lengths)
        if not quiet:
            print(f"av reward: {mean_r:.2f} av steps: {mean_l:.1f} over {len(rewards)} games", flush=True)
        return PlayResult(len(rewards), mean_r, mean_l, rewards)

    def close(self) -> None:
        self.env.close()
