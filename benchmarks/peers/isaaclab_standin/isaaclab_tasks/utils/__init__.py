"""``parse_env_cfg``, ``load_cfg_from_registry``, ``get_checkpoint_path`` as Isaac Lab's play.py uses them."""

import importlib
import os
import re

import gymnasium as gym
import yaml


def load_cfg_from_registry(task_name: str, entry_point_key: str):
    entry = gym.spec(task_name.split(":")[-1]).kwargs[entry_point_key]
    module_name, _, target = entry.partition(":")
    if target.endswith(".yaml"):
        folder = os.path.dirname(importlib.import_module(module_name).__file__)
        with open(os.path.join(folder, target)) as f:
            return yaml.safe_load(f)
    return getattr(importlib.import_module(module_name), target)()


def parse_env_cfg(task_name: str, device: str = "cpu", num_envs: int | None = None, **kwargs):
    cfg = load_cfg_from_registry(task_name, "env_cfg_entry_point")
    cfg.sim.device = device
    if num_envs is not None:
        cfg.scene.num_envs = num_envs
    return cfg


def get_checkpoint_path(log_path: str, run_dir: str = ".*", checkpoint: str = ".*",
                        other_dirs: list[str] | None = None, sort_alpha: bool = True) -> str:
    """The newest run folder matching ``run_dir`` and in it the last file matching ``checkpoint``."""
    runs = sorted(e.path for e in os.scandir(log_path) if e.is_dir() and re.match(run_dir, e.name))
    if not runs:
        raise ValueError(f"No runs present in the directory: '{log_path}' match: '{run_dir}'.")
    run_path = os.path.join(runs[-1], *(other_dirs or []))
    files = [f for f in os.listdir(run_path) if re.match(checkpoint, f)]
    if not files:
        raise ValueError(f"No checkpoints in the directory: '{run_path}' match '{checkpoint}'.")
    files.sort(key=lambda m: f"{m:0>15}")
    return os.path.join(run_path, files[-1])
