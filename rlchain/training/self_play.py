"""Self-play: the env's opponent is a frozen copy of a past policy, refreshed as the agent improves.

The env side (``envs/`` never imports models, so it gets an opaque callable)::

    env.set_opponent(policy, env_ids=None)   # policy(obs (k, *obs_shape) np) -> actions (k, ...) np;
                                             # env_ids: env indices (not agent rows); None = all
    env.pop_scores() -> np.ndarray           # optional (check_scores): per-game scores of the games
                                             # finished since the last call, e.g. win 1, draw 0.5, loss 0

:class:`SelfPlayCallback` (added by the trainer when ``self_play_config`` is set) gathers the
score of every game finished since the last opponent update: the env's ``pop_scores()`` with
``check_scores``, else each game's episode reward. After an epoch, once ``games_to_check`` games
are in and their mean is above ``update_score``, a :class:`FrozenPolicy` of the current model
becomes the opponent of ``env_update_num`` envs (a window that moves on by one env per update,
as rl_games does), and the count starts again. A resumed run starts with its own policy as the
opponent everywhere (opponents are not checkpointed).
"""

from __future__ import annotations

import copy
from collections import deque

import numpy as np
import torch

from rlchain.config.errors import ConfigError
from rlchain.config.ppo import SelfPlayConfig
from rlchain.envs.spec import env_spec
from rlchain.envs.vecenv import VecEnv
from rlchain.log import get_logger
from rlchain.training.callback_context import CallbackContext
from rlchain.training.events import Callback

log = get_logger(__name__)

KEY = "params.config.self_play_config"


class FrozenPolicy:
    """A frozen CPU copy of a model as an opponent: obs (k, *obs_shape) numpy -> env actions (k, ...).

    ``deterministic`` plays the distribution's mode, otherwise actions are sampled. Picklable, so
    it can be sent to env worker processes.
    """

    def __init__(self, model: torch.nn.Module, deterministic: bool = False) -> None:
        if getattr(model, "is_rnn", False):
            raise ValueError("self-play opponents must be feedforward policies (the RNN state of a "
                             "frozen opponent is not tracked)")
        self.model = copy.deepcopy(model).to("cpu").eval()
        self.model.requires_grad_(False)
        self.deterministic = deterministic

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            out = self.model.act(torch.as_tensor(np.asarray(obs)), deterministic=self.deterministic)
            return self.model.dist.to_env(out["actions"]).cpu().numpy()


class SelfPlayCallback(Callback):
    """Replaces the env's opponent by the current policy whenever it wins often enough."""

    def __init__(self, cfg: SelfPlayConfig, env: VecEnv, source: str = "") -> None:
        spec = env_spec(env)
        if not spec.self_play:
            raise ConfigError(source, KEY, "needs an env with set_opponent(policy, env_ids) (for example "
                                           "env_name: duel); this env has none")
        if cfg.check_scores and not spec.scores:
            raise ConfigError(source, f"{KEY}.check_scores", "True needs an env with pop_scores(); "
                                                             "this env has none (use check_scores: False)")
        self.cfg = cfg
        self.env = env
        self.num_actors = spec.num_actors
        self.scores: deque[float] = deque(maxlen=cfg.games_to_check)
        self.first_env = 0  # start of the window of envs the next update goes to
        self.updates = 0
        self.epochs_since_update = 0
        self._games_seen = 0

    def on_train_start(self, ctx: CallbackContext) -> None:
        self._games_seen = ctx.episode_tracker.games
        self._drain()
        if ctx.state.epoch > 0:  # resumed: the opponent was not saved, the resumed policy stands in
            self.env.set_opponent(FrozenPolicy(ctx.model, self.cfg.deterministic), None)

    def on_epoch_end(self, ctx: CallbackContext, stats: dict, episodes: dict | None) -> None:
        self.epochs_since_update += 1
        self.scores.extend(self._new_scores(ctx))
        if len(self.scores) < self.cfg.games_to_check:
            return
        score = float(np.mean(self.scores))
        ctx.scalar("selfplay/score", score)
        if score > self.cfg.update_score:
            self.update(ctx, score)

    def update(self, ctx: CallbackContext, score: float) -> list[int]:
        """Load a frozen copy of the policy into the next window of envs; returns their indices."""
        count = min(self.cfg.env_update_num, self.num_actors)
        env_ids = [(self.first_env + k) % self.num_actors for k in range(count)]
        self.env.set_opponent(FrozenPolicy(ctx.model, self.cfg.deterministic), env_ids)
        self.first_env = (self.first_env + 1) % self.num_actors
        self.updates += 1
        # rl_games' tag (its spelling): epochs since the previous update
        ctx.scalar("selfplay/iters_update_weigths", self.epochs_since_update)
        ctx.scalar("selfplay/updates", self.updates)
        if ctx.params.config.print_stats:
            where = f"env(s) {env_ids}" if len(env_ids) <= 4 else f"{len(env_ids)} envs"
            log.info(f"self-play: mean score {score:.3f} > {self.cfg.update_score} over {len(self.scores)} games: "
                     f"the opponent of {where} is now the policy of epoch {ctx.state.epoch} (update {self.updates})")
        self.scores.clear()
        self.epochs_since_update = 0
        self._drain()
        ctx.emit("on_stats_cleared")  # rl_games clears its game statistics here (AlgoObserver.after_clear_stats)
        return env_ids

    def _new_scores(self, ctx: CallbackContext) -> list[float]:
        """Scores of the games finished since the last call."""
        if self.cfg.check_scores:
            return [float(s) for s in np.asarray(self.env.pop_scores()).reshape(-1)]
        tracker = ctx.episode_tracker
        new = min(tracker.games - self._games_seen, len(tracker.finished_returns))
        self._games_seen = tracker.games
        return list(tracker.finished_returns)[len(tracker.finished_returns) - new:] if new > 0 else []

    def _drain(self) -> None:
        """Forget env scores of games played before now (against a previous opponent)."""
        if self.cfg.check_scores:
            self.env.pop_scores()
