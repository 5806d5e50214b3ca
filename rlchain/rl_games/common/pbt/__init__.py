"""rl_games 2.0's ``common.pbt`` names as train scripts build them (IsaacGymEnvs' and Isaac Lab's ``train.py``):
``MultiObserver([...])`` (several observers as one), ``PbtCfg`` (the ``pbt`` section, checked) and
``PbtAlgoObserver(params, args)``. rlchain's population-based training is Ray Tune's PBT (``--tune`` with
``backend: ray``, docs/tuning.md), not rl_games' re-exec lineage: a ``PbtAlgoObserver`` whose ``pbt`` section is
disabled (rl_games' default) observes nothing, as rl_games', and an enabled one is a one-line error naming it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from rlchain.errors import did_you_mean
from rlchain.rl_games.agents import package_getattr
from rlchain.rl_games.common.algo_observer import AlgoObserver

RLCHAIN_PBT = ("rlchain's population-based training is Ray Tune's PBT: `rlchain train CONFIG --tune SEARCH.yaml` "
               "with `backend: ray` and a PBT scheduler (docs/tuning.md); rl_games' re-exec PBT is not offered")


class MultiObserver(AlgoObserver):
    """Several observers as one: each call goes to every observer, in order."""

    def __init__(self, observers_: list[Any]) -> None:
        super().__init__()
        self.observers = list(observers_)

    def _call_multi(self, method: str, *args: Any, **kwargs: Any) -> None:
        for observer in self.observers:
            getattr(observer, method)(*args, **kwargs)

    def before_init(self, base_name: str, config: dict, experiment_name: str) -> None:
        self._call_multi("before_init", base_name, config, experiment_name)

    def after_init(self, algo: Any) -> None:
        self._call_multi("after_init", algo)

    def process_infos(self, infos: Any, done_indices: Any) -> None:
        self._call_multi("process_infos", infos, done_indices)

    def after_steps(self) -> None:
        self._call_multi("after_steps")

    def after_clear_stats(self) -> None:
        self._call_multi("after_clear_stats")

    def after_print_stats(self, frame: int, epoch_num: int, total_time: float) -> None:
        self._call_multi("after_print_stats", frame, epoch_num, total_time)


@dataclass
class PbtCfg:
    """rl_games 2.0's ``pbt`` section (DexPBT's keys), checked: an unknown key is an error with a did-you-mean."""

    enabled: bool = False
    policy_idx: int = 0
    num_policies: int = 8
    directory: str = ""
    workspace: str = "pbt_workspace"
    objective: str = ""
    interval_steps: int = 100_000
    threshold_std: float = 0.10
    threshold_abs: float = 0.05
    mutation_rate: float = 0.25
    change_range: tuple[float, float] = (1.1, 2.0)
    mutation: dict[str, str] = field(default_factory=dict)
    launcher: str = ""  # rl_games' re-exec executable; kept as given (rlchain restarts nothing)

    def __post_init__(self) -> None:
        self.change_range = tuple(self.change_range)  # a YAML list, as rl_games normalizes it

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None) -> PbtCfg:
        known = [f.name for f in dataclasses.fields(cls)]
        data = dict(data or {})
        for key in data:
            if key not in known:
                raise ValueError(f"pbt.{key}: unknown key{did_you_mean(key, known)} (PbtCfg: {', '.join(known)})")
        return cls(**data)


class PbtAlgoObserver(AlgoObserver):
    """rl_games' PBT observer: with ``params['pbt']`` disabled (or absent) it observes nothing; enabled, a one-line
    error naming rlchain's PBT (see the module docstring)."""

    def __init__(self, params: dict[str, Any], args_cli: Any = None) -> None:
        super().__init__()
        self.cfg = PbtCfg.from_dict((params or {}).get("pbt"))
        if self.cfg.enabled:
            raise NotImplementedError(f"pbt.enabled: {RLCHAIN_PBT}")


def __getattr__(name: str) -> Any:
    return package_getattr("rl_games.common.pbt", name)


__all__ = ["MultiObserver", "PbtAlgoObserver", "PbtCfg"]
