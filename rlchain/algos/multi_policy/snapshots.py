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

import copy
from collections import deque
from typing import Any

import numpy as np
import torch

from rlchain.config.errors import ConfigError
from rlchain.config.ppo import SelfPlayConfig
from rlchain.log import get_logger

log = get_logger(__name__)


class Snapshots:
    """Copies each trained policy into its frozen snapshot policy when it scores well enough; the
    multi-policy algorithm calls :meth:`start` and :meth:`end_epoch` with itself."""

    def __init__(self, cfg: SelfPlayConfig, snapshots: dict[str, str], source: str = "") -> None:
        if not snapshots:
            raise ConfigError(source, "params.config.self_play_config", "with multi_agent, self-play needs "
                              "multi_agent.snapshots: {<frozen policy>: <trained policy>}")
        self.cfg, self.snapshots = cfg, dict(snapshots)
        self.scores = {trained: deque(maxlen=cfg.games_to_check) for trained in self.snapshots.values()}
        self.seen = dict.fromkeys(self.scores, 0)
        self.updates = 0
        self.first_env = 0  # start of the window of envs the next refresh goes to
        self.pools: dict[str, SnapshotPool] = {}  # frozen policy -> its past snapshots env by env (from start())

    def start(self, algo: Any) -> None:
        for trained in self.seen:
            self.seen[trained] = algo.learner(trained).tracker.games
        for frozen, trained in self.snapshots.items():
            self.pools[frozen] = SnapshotPool(algo.learner(frozen).model, algo.num_envs)
            if algo.ctx.epoch == 0:  # the opponent starts as the learner's starting self, everywhere
                self.pools[frozen].refresh(algo.model[trained], list(range(algo.num_envs)))

    def refresh(self, algo: Any, frozen: str, trained: str) -> list[int]:
        """The trained policy's weights into the frozen one, for the next window of envs."""
        count = min(self.cfg.env_update_num, algo.num_envs)
        env_ids = [(self.first_env + k) % algo.num_envs for k in range(count)]
        self.first_env = (self.first_env + 1) % algo.num_envs
        self.pools[frozen].refresh(algo.model[trained], env_ids)
        return env_ids

    def end_epoch(self, algo: Any) -> None:
        for frozen, trained in self.snapshots.items():
            tracker = algo.learner(trained).tracker
            new = min(tracker.games - self.seen[trained], len(tracker.finished_returns))
            self.seen[trained] = tracker.games
            returns = list(tracker.finished_returns)[len(tracker.finished_returns) - new:] if new > 0 else []
            scores = self.scores[trained]
            scores.extend(_score(r, self.cfg.check_scores) for r in returns)
            if len(scores) < self.cfg.games_to_check:
                continue
            score = float(np.mean(scores))
            algo.ctx.logger.scalar(f"selfplay/{trained}/score", score, algo.ctx.frames)
            if score > self.cfg.update_score:
                env_ids = self.refresh(algo, frozen, trained)
                self.updates += 1
                scores.clear()
                algo.ctx.logger.scalar("selfplay/updates", self.updates, algo.ctx.frames)
                if algo.cfg.print_stats:
                    where = f"env(s) {env_ids}" if len(env_ids) <= 4 else f"{len(env_ids)} envs"
                    log.info(f"self-play: {trained} scored {score:.3f} > {self.cfg.update_score}: {frozen} in {where} "
                             f"is now its snapshot of epoch {algo.ctx.epoch} (update {self.updates})")


class SnapshotPool:
    """The snapshots a frozen policy plays with, env by env: ``model`` (the policy's own module, the
    newest snapshot) and older copies still played in some envs."""

    def __init__(self, model: torch.nn.Module, num_envs: int) -> None:
        self.model, self.num_envs = model, num_envs
        self.older: dict[int, torch.nn.Module] = {}
        self.env_version = np.zeros(num_envs, dtype=np.int64)  # 0: the newest (``model``)
        self._next = 1

    def refresh(self, source: torch.nn.Module, env_ids: list[int]) -> None:
        """``source``'s weights become the newest snapshot, played in ``env_ids``; the other envs
        that played the newest keep a frozen copy of it."""
        keep = np.setdiff1d(np.flatnonzero(self.env_version == 0), env_ids)
        if keep.size:
            self.older[self._next] = copy.deepcopy(self.model).eval().requires_grad_(False)
            self.env_version[keep] = self._next
            self._next += 1
        self.model.load_state_dict(source.state_dict())
        self.env_version[env_ids] = 0
        for version in [v for v in self.older if not (self.env_version == v).any()]:
            del self.older[version]

    def act(self, obs: torch.Tensor, agents: int, masks: torch.Tensor | None) -> torch.Tensor:
        """Actions for the policy's rows (agent-major, ``agents`` per env), each env's by its snapshot."""
        if not self.older:
            return self.model.act(obs, action_masks=masks)["actions"]
        versions = torch.as_tensor(np.tile(self.env_version, agents), device=obs.device)
        actions = None
        for version, module in [(0, self.model), *self.older.items()]:
            rows = (versions == version).nonzero().squeeze(-1)
            if rows.numel() == 0:
                continue
            out = module.act(obs[rows], action_masks=None if masks is None else masks[rows])["actions"]
            if actions is None:
                actions = torch.empty((obs.shape[0], *out.shape[1:]), dtype=out.dtype, device=out.device)
            actions[rows] = out
        return actions


def _score(episode_return: float, outcome: bool) -> float:
    if not outcome:
        return float(episode_return)
    return 1.0 if episode_return > 0 else (0.5 if episode_return == 0 else 0.0)
