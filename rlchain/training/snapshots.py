"""Self-play with the policy mapping: frozen snapshot policies refreshed on rl_games' rule.

``multi_agent.snapshots: {opponent: learner}`` makes the frozen policy ``opponent`` a copy of the
trained policy ``learner``: at the start of a run, and again after an epoch once ``games_to_check``
games of ``learner`` have finished since the last refresh and their mean score is above
``update_score`` (``self_play_config``, rl_games' keys). A game's score is the learner's episode
return, or with ``check_scores`` its outcome: 1 for a positive return (a win), 0.5 for zero (a
draw), 0 for a negative one. The snapshot is a policy of the checkpoint, so a resumed run goes on
against the same opponent. ``env_update_num`` does not apply: every env gets the new snapshot.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np

from rlchain.config.errors import ConfigError
from rlchain.config.schema import SelfPlayConfig
from rlchain.log import get_logger
from rlchain.training.events import Callback

log = get_logger(__name__)


class SnapshotCallback(Callback):
    """Copies each trained policy into its frozen snapshot policy when it scores well enough."""

    def __init__(self, cfg: SelfPlayConfig, snapshots: dict[str, str], source: str = "") -> None:
        if not snapshots:
            raise ConfigError(source, "params.config.self_play_config", "with multi_agent, self-play needs "
                              "multi_agent.snapshots: {<frozen policy>: <trained policy>}")
        self.cfg, self.snapshots = cfg, dict(snapshots)
        self.scores = {trained: deque(maxlen=cfg.games_to_check) for trained in self.snapshots.values()}
        self.seen = dict.fromkeys(self.scores, 0)
        self.updates = 0

    def on_train_start(self, trainer: Any) -> None:
        for trained in self.seen:
            self.seen[trained] = trainer.learner(trained).tracker.games
        if trainer.epoch == 0:  # the opponent starts as the learner's starting self
            for frozen, trained in self.snapshots.items():
                self.refresh(trainer, frozen, trained)

    def refresh(self, trainer: Any, frozen: str, trained: str) -> None:
        trainer.model[frozen].load_state_dict(trainer.model[trained].state_dict())

    def on_epoch_end(self, trainer: Any, stats: dict, episodes: dict | None) -> None:
        for frozen, trained in self.snapshots.items():
            tracker = trainer.learner(trained).tracker
            new = min(tracker.games - self.seen[trained], len(tracker.finished_returns))
            self.seen[trained] = tracker.games
            returns = list(tracker.finished_returns)[len(tracker.finished_returns) - new:] if new > 0 else []
            scores = self.scores[trained]
            scores.extend(_score(r, self.cfg.check_scores) for r in returns)
            if len(scores) < self.cfg.games_to_check:
                continue
            score = float(np.mean(scores))
            trainer.logger.scalar(f"selfplay/{trained}/score", score, trainer.frames)
            if score > self.cfg.update_score:
                self.refresh(trainer, frozen, trained)
                self.updates += 1
                scores.clear()
                trainer.logger.scalar("selfplay/updates", self.updates, trainer.frames)
                if trainer.cfg.print_stats:
                    log.info(f"self-play: {trained} scored {score:.3f} > {self.cfg.update_score}: {frozen} is now "
                             f"its snapshot of epoch {trainer.epoch} (update {self.updates})")


def _score(episode_return: float, outcome: bool) -> float:
    if not outcome:
        return float(episode_return)
    return 1.0 if episode_return > 0 else (0.5 if episode_return == 0 else 0.0)
