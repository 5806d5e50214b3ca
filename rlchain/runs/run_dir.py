"""Run folders laid out as rl_games does: ``<train_dir>/<name>_<date-time>/{nn,summaries}``."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import yaml


@dataclass
class RunDir:
    """Paths of one run."""

    root: str
    name: str
    layout: str = "rlchain"
    """``rl_games``: checkpoint names as rl_games writes them (:mod:`rlchain.runs.rl_games_layout`)."""

    @property
    def nn(self) -> str:
        return os.path.join(self.root, "nn")

    @property
    def summaries(self) -> str:
        return os.path.join(self.root, "summaries")

    def checkpoint(self, kind: str = "best") -> str:
        """best: nn/<name>.pth; last: nn/last_<name>.pth; ep_N: nn/<name>_ep_N.pth; file:STEM: nn/STEM.pth."""
        if kind.startswith("file:"):
            return os.path.join(self.nn, f"{kind[len('file:'):]}.pth")
        if kind == "best":
            return os.path.join(self.nn, f"{self.name}.pth")
        if kind == "last":
            return os.path.join(self.nn, f"last_{self.name}.pth")
        return os.path.join(self.nn, f"{self.name}_{kind}.pth")


def create_run_dir(train_dir: str, name: str, experiment: str | None, raw_config: dict) -> RunDir:
    """Make the folders (failing early with a clear message) and store the config used."""
    folder = experiment or f"{name}_{time.strftime('%d-%H-%M-%S')}"
    root = os.path.join(train_dir, folder)
    if experiment is None and os.path.exists(root):
        root = f"{root}_{os.getpid()}"
    try:
        os.makedirs(os.path.join(root, "nn"), exist_ok=True)
        os.makedirs(os.path.join(root, "summaries"), exist_ok=True)
        with open(os.path.join(root, "config.yaml"), "w", encoding="utf-8") as fh:
            yaml.safe_dump(raw_config, fh, sort_keys=False)
    except OSError as exc:
        raise OSError(f"cannot create run folder '{root}': {exc.strerror or exc}") from None
    return RunDir(root=root, name=name)
