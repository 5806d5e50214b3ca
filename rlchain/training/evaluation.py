"""In-training evaluation: :class:`EvaluationCallback` plays the policy on its own envs with
:func:`rlchain.policy.play.play` (the loop the Player, video and export share)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import torch

from rlchain.envs.vecenv import VecEnv
from rlchain.log import get_logger
from rlchain.policy.play import EpisodeSuccess, PlayResult, play
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback

log = get_logger(__name__)

__all__ = ["EpisodeSuccess", "EvaluationCallback", "PlayResult", "run_episodes"]


def run_episodes(model: Any, env: VecEnv, games: int, deterministic: bool, device: torch.device,
                 seed: int | None = None, on_game: Callable[[int, float, int, float | None], None] | None = None,
                 render_sleep: float | None = None, success_key: str = "auto",
                 success_mode: str = "any") -> PlayResult:
    """Play ``games`` finished episodes on ``env`` with ``model``: :func:`rlchain.policy.play.play`
    under its former name and positional order."""
    return play(model, env, games, deterministic, device=device, seed=seed, on_game=on_game,
                render_sleep=render_sleep, success_key=success_key, success_mode=success_mode)


class EvaluationCallback(Callback):
    """Evaluates the policy every ``interval`` epochs on its own envs and logs ``evaluation/*``.

    With ``select_best: evaluation`` the best checkpoint follows the evaluation score. The envs are
    closed at the end of training, or by :meth:`close` when the run fails (``Loop.close``).
    """

    def __init__(self, cfg: Any, make_env: Callable[[int, int], Any]) -> None:
        self.cfg = cfg
        self.env = make_env(cfg.num_envs, cfg.seed)
        self.best: Any = None  # the best score so far (a float, or a (success, reward) pair)

    def on_epoch_end(self, ctx: CallbackContext, stats: dict, episodes: dict | None) -> None:
        state, config = ctx.state, ctx.params.config
        if state.epoch % self.cfg.interval != 0:
            return
        result = play(ctx.model, self.env, self.cfg.games, self.cfg.deterministic, device=state.device,
                      seed=self.cfg.seed, success_key=config.success_key, success_mode=config.success_mode)
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
        score = _score(self.cfg.select_best, result)
        if is_better(score, self.best, self.cfg.best_mode):
            self.best = score
            if state.epoch >= config.save_best_after:
                ctx.save("best")

    def on_train_end(self, ctx: CallbackContext, result: Any) -> None:
        self.close()

    def close(self) -> None:
        """Close the evaluation env (once; the trainer also calls this when a run fails)."""
        env, self.env = self.env, None
        if env is not None:
            env.close()


def is_better(score: Any, best: Any, mode: str = "max") -> bool:
    """Whether ``score`` beats ``best`` (None: nothing yet) under ``mode`` (max or min); a None score never does."""
    if score is None:
        return False
    return best is None or (score < best if mode == "min" else score > best)


def _score(select_best: str, result: PlayResult) -> Any:
    """What ``select_best`` ranks evaluations by (None: evaluations do not pick the best checkpoint)."""
    if select_best == "evaluation":
        return result.mean_reward
    if select_best == "evaluation_length":
        return result.mean_length
    if select_best == "evaluation_success":
        return (result.success_rate if result.success_rate is not None else float("-inf"), result.mean_reward)
    return None
