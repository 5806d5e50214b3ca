"""Inference from a checkpoint: deterministic or stochastic play over ``games_num`` episodes."""

from __future__ import annotations

from rlchain.config.params import Params
from rlchain.policy.load import load_policy
from rlchain.policy.play import PlayResult, play


class Player:
    """Loads a checkpoint into a freshly built model and plays episodes.

    The env count comes from ``player.num_actors`` (1 by default), not from training's num_actors.
    """

    def __init__(self, params: Params, checkpoint_path: str | None, device: str | None = None,
                 sigma: float | None = None) -> None:
        self.params = params
        cfg = params.config
        self.player_cfg = cfg.player
        self.num_envs = self.player_cfg.num_actors if self.player_cfg.use_vecenv else 1
        seed = params.seed if params.seed is not None else 0
        policy = load_policy(params, checkpoint_path, device=device, num_envs=self.num_envs, seed=seed,
                             render=self.player_cfg.render, env_config=self.player_cfg.env_config, sigma=sigma)
        self.model, self.env, self.device = policy.model, policy.env, policy.device
        self.seed = seed

    def play(self, games: int | None = None, deterministic: bool | None = None,
             quiet: bool = False) -> PlayResult:
        """Play ``games`` episodes (default player.games_num) and report their mean reward/length."""
        pc = self.player_cfg
        games = games or pc.games_num
        deterministic = pc.deterministic if deterministic is None else deterministic

        def report(index: int, reward: float, length: int, success: float | None) -> None:
            if pc.print_stats and not quiet:
                won = "" if success is None else f" success {'yes' if success else 'no'}"
                print(f"game {index}: reward {reward:.2f} steps {length}{won}", flush=True)

        cfg = self.params.config
        result = play(self.model, self.env, games, deterministic, device=self.device, seed=self.seed,
                      on_game=report, render_sleep=pc.render_sleep if pc.render else None,
                      success_key=cfg.success_key, success_mode=cfg.success_mode)
        if not quiet:
            rate = result.success_rate
            won = "" if rate is None else f" success rate: {rate:.2f} ({len(result.successes)} games)"
            print(f"av reward: {result.mean_reward:.2f} av steps: {result.mean_length:.1f} over "
                  f"{result.games} games{won}", flush=True)
        return result

    def close(self) -> None:
        self.env.close()
