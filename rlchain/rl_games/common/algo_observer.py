"""rl_games' observers: ``AlgoObserver`` (the interface), ``DefaultAlgoObserver`` and ``IsaacAlgoObserver``.

rlchain calls an observer at rl_games' points through its callback events
(:class:`rlchain.training.events.AlgoObserverCallback`): ``before_init`` and ``after_init(algo)`` at the
start, ``process_infos(infos, done_indices)`` after every env step, ``after_steps()`` after each rollout,
``after_print_stats(frame, epoch_num, total_time)`` after each epoch's logging, ``after_clear_stats()``
where rl_games clears its game statistics. ``algo`` offers what observers read of rl_games' algo:
``writer``, ``games_to_track``, ``frame``, ``epoch_num``, ``device`` / ``ppo_device``, ``num_actors``,
``num_agents``, ``config``, ``experiment_dir``. An observer written for rl_games runs unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from rlchain.rl_games.algos_torch.torch_ext import AverageMeter


class AlgoObserver:
    """Base class: every method is a no-op; override those you need."""

    def before_init(self, base_name: str, config: dict, experiment_name: str) -> None:
        """Before the algorithm is built: run name, the config as loaded, the run folder."""

    def after_init(self, algo: Any) -> None:
        """Once the algorithm exists; keep ``algo`` to read its ``writer``, ``frame``, ``epoch_num`` later."""

    def process_infos(self, infos: Any, done_indices: torch.Tensor) -> None:
        """After every env step: the env's infos and the (k, 1) rows whose episode ended."""

    def after_steps(self) -> None:
        """After each rollout, before the update."""

    def after_clear_stats(self) -> None:
        """Game statistics were cleared (self-play replaced the opponent)."""

    def after_print_stats(self, frame: int, epoch_num: int, total_time: float) -> None:
        """After each epoch's statistics were logged."""


def _scalar_of(value: Any) -> float | None:
    """``value`` as a float when it is one number (int, float, numpy scalar, 0-d or one-element tensor/array);
    None for booleans and anything else."""
    if isinstance(value, (bool, np.bool_)):
        return None
    if isinstance(value, (int, float, np.number)):
        return float(value)
    if isinstance(value, torch.Tensor) and value.numel() == 1:
        return float(value.reshape(()).item())
    if isinstance(value, np.ndarray) and value.size == 1:
        return float(value.reshape(()))
    return None


def _as_array(value: Any) -> np.ndarray:
    """A score of any type rl_games accepts (a number, a numpy scalar or array of any dtype, bools included,
    a torch tensor, a list) as a float32 numpy array."""
    if isinstance(value, torch.Tensor):
        value = value.detach().cpu().numpy()
    return np.asarray(value).astype(np.float32)


def _game_result(info: dict) -> Any:
    """rl_games' game result of an info dict: ``scores``, else ``battle_won``, else None."""
    if "scores" in info:
        return info["scores"]
    return info.get("battle_won", None)


class DefaultAlgoObserver(AlgoObserver):
    """Game scores: the ``scores`` (or ``battle_won``) info of finished episodes, averaged over the last
    ``games_to_track`` games and written as ``scores/mean``, ``scores/iter``, ``scores/time``.

    As rl_games counts them: dict infos give one entry per finished row (``row // num_agents``, rows past the
    array dropped; with envpool's ``lives``, the envs with no lives left); a list of per-env dicts gives each
    finished env's entry; NaN fillers are skipped.
    """

    def after_init(self, algo: Any) -> None:
        self.algo = algo
        self.writer = algo.writer
        self.game_scores = AverageMeter(1, algo.games_to_track).to(algo.ppo_device)

    def process_infos(self, infos: Any, done_indices: Any) -> None:
        if infos is None or len(infos) == 0:
            return
        agents = max(1, int(getattr(self.algo, "num_agents", 1)))
        rows = np.asarray(_as_array(done_indices), dtype=np.int64).reshape(-1)
        if isinstance(infos, dict):
            if "lives" in infos:  # envpool: the envs whose last life ended
                rows = np.flatnonzero(_as_array(infos["lives"]).reshape(-1) == 0)
            result = _game_result(infos)
            if result is None or rows.size == 0:
                return
            result = _as_array(result)
            if result.size == 0:
                return
            if result.ndim == 0:
                entries = np.full(rows.size, float(result), np.float32)
            else:
                result = result.reshape(len(result), -1)[:, 0]
                index = rows // agents
                entries = result[index[index < len(result)]]
        elif isinstance(infos, (list, tuple)) and isinstance(infos[0], dict):
            parts = [_as_array(res).reshape(-1) for row in rows if row // agents < len(infos)
                     and (res := _game_result(infos[row // agents])) is not None]
            entries = np.concatenate(parts) if parts else np.zeros(0, np.float32)
        else:
            return
        entries = entries[np.isfinite(entries)]
        if entries.size:
            self.game_scores.update(torch.from_numpy(np.ascontiguousarray(entries)).unsqueeze(1))

    def after_clear_stats(self) -> None:
        self.game_scores.clear()

    def after_print_stats(self, frame: int, epoch_num: int, total_time: float) -> None:
        if self.game_scores.current_size > 0 and self.writer is not None:
            mean = float(self.game_scores.get_mean())
            self.writer.add_scalar("scores/mean", mean, frame)
            self.writer.add_scalar("scores/iter", mean, epoch_num)
            self.writer.add_scalar("scores/time", mean, total_time)


class IsaacAlgoObserver(AlgoObserver):
    """What Isaac Lab's envs report: per-episode statistics in ``infos['episode']`` (or ``infos['log']``,
    Isaac Lab's name before its wrapper renames it), written as ``Episode/<key>`` (mean over the epoch's
    reports) against the epoch; scalar infos written as ``<key>/frame``, ``<key>/iter``, ``<key>/time``."""

    def after_init(self, algo: Any) -> None:
        self.algo = algo
        self.writer = algo.writer
        self.mean_scores = AverageMeter(1, algo.games_to_track).to(algo.ppo_device)
        self.ep_infos: list[dict] = []
        self.direct_info: dict[str, float] = {}

    def process_infos(self, infos: Any, done_indices: torch.Tensor) -> None:
        if not isinstance(infos, dict):
            raise ValueError(f"{type(self).__name__} expects the env's infos as a dict, got {type(infos).__name__}")
        for key in ("episode", "log"):
            if isinstance(infos.get(key), dict) and infos[key]:
                self.ep_infos.append(infos[key])
        # one number per step (a float, an int or a 0-d tensor), not per-env rows such as time_outs
        direct = {k: s for k, v in infos.items()
                  if (isinstance(v, (int, float, np.number))
                      or isinstance(v, (torch.Tensor, np.ndarray)) and v.ndim == 0)
                  and (s := _scalar_of(v)) is not None}
        if direct:
            self.direct_info = direct

    def after_clear_stats(self) -> None:
        self.mean_scores.clear()

    def after_print_stats(self, frame: int, epoch_num: int, total_time: float) -> None:
        if self.ep_infos:
            for key in sorted(set().union(*self.ep_infos)):  # reports may carry different keys
                parts = [torch.as_tensor(info[key], dtype=torch.float32).reshape(-1).cpu()
                         for info in self.ep_infos if key in info]
                values = torch.cat(parts) if parts else torch.zeros(0)
                if values.numel():
                    self.writer.add_scalar("Episode/" + key, float(values.mean()), epoch_num)
            self.ep_infos.clear()
        for key, value in self.direct_info.items():
            self.writer.add_scalar(f"{key}/frame", value, frame)
            self.writer.add_scalar(f"{key}/iter", value, epoch_num)
            self.writer.add_scalar(f"{key}/time", value, total_time)
        if self.mean_scores.current_size > 0:
            mean = float(self.mean_scores.get_mean())
            self.writer.add_scalar("scores/mean", mean, frame)
            self.writer.add_scalar("scores/iter", mean, epoch_num)
            self.writer.add_scalar("scores/time", mean, total_time)


__all__ = ["AlgoObserver", "DefaultAlgoObserver", "IsaacAlgoObserver"]
