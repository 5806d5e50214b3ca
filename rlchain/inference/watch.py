"""rl_games' evaluation player: watch a folder and evaluate every new or updated checkpoint.

    from rlchain.inference.watch import watch_and_evaluate
    watch_and_evaluate(params, "runs/cartpole/nn", games=20, poll_seconds=5, timeout=3600)

The config way (rl_games ``player.evaluation``)::

    config:
      player: {evaluation: True, dir_to_monitor: runs/cartpole/nn, update_checkpoint_freq: 20}

``python runner.py --play --file cfg.yaml`` then watches ``dir_to_monitor`` (``*.pth`` files,
searched recursively), plays ``update_checkpoint_freq`` games with each new or rewritten
checkpoint and prints its score, until Ctrl-C.
"""

from __future__ import annotations

import glob
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.params import Params
from rlchain.inference.player import Player
from rlchain.policy.load import load_weights
from rlchain.policy.play import PlayResult, play
from rlchain.runs import checkpoint as ckpt


@dataclass
class CheckpointScore:
    """One evaluation of one version of a checkpoint file."""

    path: str
    mtime: float
    result: PlayResult


def list_checkpoints(folder: str) -> dict[str, tuple[int, int]]:
    """``*.pth`` under ``folder`` (recursively) -> (mtime_ns, size); temp files of atomic saves are skipped."""
    found = {}
    for path in glob.glob(os.path.join(folder, "**", "*.pth"), recursive=True):
        if os.path.basename(path).startswith("."):
            continue
        try:
            st = os.stat(path)
        except OSError:  # replaced or removed between glob and stat
            continue
        found[path] = (st.st_mtime_ns, st.st_size)
    return found


def watch_and_evaluate(params: Params, dir_to_monitor: str | None = None, games: int | None = None,
                       poll_seconds: float = 5.0, max_checkpoints: int | None = None,
                       timeout: float | None = None, deterministic: bool | None = None,
                       include_existing: bool = True, quiet: bool = False,
                       on_result: Callable[[CheckpointScore], None] | None = None) -> list[CheckpointScore]:
    """Poll ``dir_to_monitor`` for new/updated checkpoints and evaluate each over ``games`` games.

    Defaults come from ``config.player``: ``dir_to_monitor``, ``update_checkpoint_freq`` (games) and
    ``deterministic``. Stops after ``max_checkpoints`` evaluations or ``timeout`` seconds (None:
    never; Ctrl-C stops it). ``include_existing=False`` skips checkpoints already there at the start.
    Returns the scores in evaluation order.
    """

    pc = params.config.player
    folder = dir_to_monitor or pc.dir_to_monitor
    if not folder:
        raise ConfigError(params.source, "params.config.player.dir_to_monitor",
                          "is required to watch checkpoints (player.evaluation)")
    games = games or pc.update_checkpoint_freq
    deterministic = pc.deterministic if deterministic is None else deterministic
    start = time.monotonic()
    seen = {} if include_existing else list_checkpoints(folder)
    scores: list[CheckpointScore] = []
    player = Player(params, None)
    if not quiet:
        print(f"watching {folder} for checkpoints ({games} games each)", flush=True)
    try:
        while max_checkpoints is None or len(scores) < max_checkpoints:
            pending = sorted(((stamp, path) for path, stamp in list_checkpoints(folder).items()
                              if seen.get(path) != stamp), key=lambda item: (item[0][0], item[1]))
            for stamp, path in pending:
                seen[path] = stamp  # a file still being written changes its stamp and is read again
                try:
                    score = _evaluate(player, path, games, deterministic)
                except (OSError, ckpt.CheckpointError) as exc:
                    if not quiet:
                        print(f"warning: skipping {path}: {exc}", flush=True)
                    continue
                scores.append(score)
                if not quiet:
                    r = score.result
                    print(f"checkpoint {path}: av reward {r.mean_reward:.2f} av steps {r.mean_length:.1f} "
                          f"over {r.games} games", flush=True)
                if on_result is not None:
                    on_result(score)
                if max_checkpoints is not None and len(scores) >= max_checkpoints:
                    break
            else:
                if timeout is not None and time.monotonic() - start >= timeout:
                    break
                time.sleep(poll_seconds)
    finally:
        player.close()
    return scores


def _evaluate(player: Any, path: str, games: int, deterministic: bool) -> CheckpointScore:
    mtime = os.path.getmtime(path)
    load_weights(player.model, path, player.device)
    result = play(player.model, player.env, games, deterministic, device=player.device, seed=player.seed)
    return CheckpointScore(path, mtime, result)
