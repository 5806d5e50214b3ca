"""Playing episodes with a fixed policy: the Player's loop and in-training evaluation."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from rlchain.envs.success import SuccessReader
from rlchain.log import get_logger
from rlchain.models.stepper import PolicyStepper
from rlchain.training.callback_context import CallbackContext
from rlchain.training.episodes import game_outcome
from rlchain.training.events import Callback

log = get_logger(__name__)


@dataclass
class PlayResult:
    """Mean episode reward and length over the games played; ``successes`` (1.0 / 0.0) of the games
    for which the env reported task success (empty for envs that report none)."""

    games: int
    mean_reward: float
    mean_length: float
    rewards: list[float]
    successes: list[float] = field(default_factory=list)

    @property
    def success_rate(self) -> float | None:
        """Fraction of the games with a success value that succeeded; None when the env reports none."""
        return sum(self.successes) / len(self.successes) if self.successes else None


class EpisodeSuccess:
    """Per-env task success of the episodes in progress while playing (see ``envs/success.py``)."""

    def __init__(self, num_envs: int, key: str, mode: str) -> None:
        self.reader = SuccessReader(key)
        self.mode = mode
        self.seen = np.zeros(num_envs, bool)
        self.any = np.zeros(num_envs, bool)
        self.last = np.zeros(num_envs, bool)

    def step(self, infos: Any, dones: Any) -> None:
        values = self.reader.read(infos, dones)
        if values is None:
            return
        seen = ~np.isnan(values)
        hit = seen & (np.nan_to_num(values) > 0.5)
        self.seen |= seen
        self.any |= hit
        self.last[seen] = hit[seen]

    def pop(self, i: int) -> float | None:
        """Env ``i``'s finished episode: 1.0 / 0.0, or None without a success value; clears the row."""
        result = float((self.any if self.mode == "any" else self.last)[i]) if self.seen[i] else None
        self.seen[i] = self.any[i] = self.last[i] = False
        return result


def run_episodes(model: Any, env: Any, games: int, deterministic: bool, device: torch.device,
                 seed: int | None = None, on_game: Callable[[int, float, int, float | None], None] | None = None,
                 render_sleep: float | None = None, success_key: str = "auto",
                 success_mode: str = "any") -> PlayResult:
    """Play ``games`` finished episodes on ``env`` (any VecEnv) with ``model`` and report them.

    ``on_game(index, reward, length, success)`` is called per finished game (success None when the
    env reports none); ``render_sleep`` renders each step. The model's mode is used when
    ``deterministic``; no gradient is tracked. ``success_key`` / ``success_mode``: as the config keys.
    """
    dist = model.dist
    tensor_env = bool(getattr(env, "is_tensor_env", False))
    obs = torch.as_tensor(env.reset(seed=seed), device=device)
    returns = torch.zeros(env.num_envs, dtype=torch.float64)
    lengths = torch.zeros(env.num_envs, dtype=torch.long)
    rewards: list[float] = []
    episode_lengths: list[int] = []
    successes: list[float] = []
    success = EpisodeSuccess(env.num_envs, success_key, success_mode)
    was_training = model.training
    model.eval()
    policy = PolicyStepper(model, env.num_envs, device)
    try:
        while len(rewards) < games:
            actions = dist.to_env(policy.act(obs, env, deterministic))
            result = env.step(actions if tensor_env else actions.cpu().numpy())
            reward = torch.as_tensor(result.reward, dtype=torch.float64).cpu()
            reward = reward.sum(-1) if reward.dim() > 1 else reward
            lengths += 1
            done = (torch.as_tensor(result.terminated) | torch.as_tensor(result.truncated)).cpu()
            policy.done(done)
            success.step(result.infos, done.numpy())
            reward, game_over = game_outcome(result, reward, done)  # whole games (Atari lives)
            returns += reward
            for i in game_over.nonzero().flatten().tolist():
                won = success.pop(i)
                if len(rewards) < games:
                    rewards.append(float(returns[i]))
                    episode_lengths.append(int(lengths[i]))
                    if won is not None:
                        successes.append(won)
                    if on_game is not None:
                        on_game(len(rewards), rewards[-1], episode_lengths[-1], won)
                returns[i], lengths[i] = 0.0, 0
            if render_sleep is not None:
                env.render()
                time.sleep(render_sleep)
            obs = torch.as_tensor(result.obs, device=device)
    finally:
        model.train(was_training)
    return PlayResult(len(rewards), sum(rewards) / len(rewards), sum(episode_lengths) / len(episode_lengths),
                      rewards, successes)


class EvaluationCallback(Callback):
    """Evaluates the policy every ``interval`` epochs on its own envs and logs ``evaluation/*``.

    With ``select_best: evaluation`` the best checkpoint follows the evaluation score. The envs are
    closed at the end of training, or by :meth:`close` when the run fails (``TrainerBase.close``).
    """

    def __init__(self, cfg: Any, make_env: Callable[[int, int], Any]) -> None:
        self.cfg = cfg
        self.env = make_env(cfg.num_envs, cfg.seed)
        self.best = float("-inf")

    def on_epoch_end(self, ctx: CallbackContext, stats: dict, episodes: dict | None) -> None:
        state, config = ctx.state, ctx.params.config
        if state.epoch % self.cfg.interval != 0:
            return
        result = run_episodes(ctx.model, self.env, self.cfg.games, self.cfg.deterministic,
                              state.device, seed=self.cfg.seed, success_key=config.success_key,
                              success_mode=config.success_mode)
        scalar = ctx.writer.add_scalar
        scalar("evaluation/rewards", result.mean_reward, state.frames)
        scalar("evaluation/rewards_iter", result.mean_reward, state.epoch)
        scalar("evaluation/episode_lengths", result.mean_length, state.frames)
        rate = result.success_rate
        if rate is not None:
            scalar("evaluation/success_rate", rate, state.frames)
        if config.print_stats:
            won = f" success {rate:.2f}" if rate is not None else ""
            log.info(f"evaluation at epoch {state.epoch}: reward {result.mean_reward:.2f} length "
                     f"{result.mean_length:.1f}{won} over {result.games} games")
        ctx.emit("on_evaluation", result)
        if self.cfg.select_best == "evaluation" and result.mean_reward > self.best:
            self.best = result.mean_reward
            if state.epoch >= config.save_best_after:
                ctx.save("best")

    def on_train_end(self, ctx: CallbackContext, result: Any) -> None:
        self.close()

    def close(self) -> None:
        """Close the evaluation env (once; the trainer also calls this when a run fails)."""
        env, self.env = self.env, None
        if env is not None:
            env.close()
