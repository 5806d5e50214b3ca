"""Run folders laid out as rl_games does: ``<train_dir>/<name>_<date-time>/{nn,summaries}``."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import yaml

from rlchain.runs.atomic import remove_stale_temps, write_text_atomic


@dataclass
class RunDir:
    """Paths of one run."""

    root: str
    name: str
    layout: str = "rlchain"
    """``rl_games``: checkpoint names as rl_games writes them (:mod:`rlchain.runs.rl_games_layout`);
    ``embodichain``: as EmbodiChain's trainer does (``<name>_best.pt``, ``<name>_step_<frames>.pt``)."""

    @property
    def nn(self) -> str:
        return os.path.join(self.root, "nn")

    @property
    def summaries(self) -> str:
        return os.path.join(self.root, "summaries")

    def checkpoint(self, kind: str = "best") -> str:
        """best: nn/<name>.pth; last: nn/last_<name>.pth; ep_N: nn/<name>_ep_N.pth; file:STEM: nn/STEM.pth.
        In the ``embodichain`` layout best is nn/<name>_best.pt and file:STEM nn/STEM.pt."""
        suffix = ".pt" if self.layout == "embodichain" else ".pth"
        if kind.startswith("file:"):
            return os.path.join(self.nn, f"{kind[len('file:'):]}{suffix}")
        if kind == "best" and self.layout == "embodichain":
            return os.path.join(self.nn, f"{self.name}_best.pt")
        if kind == "best":
            return os.path.join(self.nn, f"{self.name}.pth")
        if kind == "last":
            return os.path.join(self.nn, f"last_{self.name}.pth")
        return os.path.join(self.nn, f"{self.name}_{kind}.pth")


def create_run_dir(train_dir: str, name: str, experiment: str | None, raw_config: dict,
                   layout: str = "rlchain") -> RunDir:
    """Make the folders (failing early with a clear message) and store the config used; ``layout``: the
    checkpoint names (:attr:`RunDir.layout`).

    The run folder must lie inside ``train_dir`` (the config's name checks keep it so; this is the last
    guard), its ``nn`` and ``summaries`` must be real folders (not symlinks planted to send files
    elsewhere), and temp files a killed writer left there are removed."""
    folder = experiment or f"{name}_{time.strftime('%d-%H-%M-%S')}"
    root = os.path.join(train_dir, folder)
    if experiment is None and os.path.exists(root):
        root = f"{root}_{os.getpid()}"
    base = os.path.realpath(train_dir)
    if os.path.dirname(os.path.realpath(root)) != base:
        raise OSError(f"cannot create run folder '{root}': it is not a folder directly inside train_dir "
                      f"'{train_dir}' (name and full_experiment_name are names, not paths)")
    try:
        for sub in ("nn", "summaries"):
            path = os.path.join(root, sub)
            if os.path.islink(path):
                raise OSError(f"'{path}' is a symlink; a run writes into its own folders only")
            os.makedirs(path, exist_ok=True)
        for sub in ("", "nn"):
            remove_stale_temps(os.path.join(root, sub))
        write_text_atomic(os.path.join(root, "config.yaml"), yaml.safe_dump(raw_config, sort_keys=False))
    except OSError as exc:
        raise OSError(f"cannot create run folder '{root}': {exc.strerror or exc}") from None
    return RunDir(root=root, name=name, layout=layout)
