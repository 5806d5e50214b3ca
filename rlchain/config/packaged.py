"""The configs and checkpoints shipped inside the rlchain package, found by a short name or a path.

A wheel install has no clone to run from, so ``rlchain train ppo_cartpole`` names the packaged
``rlchain/configs/ppo_cartpole.yaml``. A config name is its path under ``rlchain/configs/`` without the
extension (``ppo_cartpole``, ``tune/tune_cartpole``, ``rl_games/halfcheetah_envpool``); a file name
that is unique in the tree works alone (``halfcheetah_envpool``), and a folder with one config in it is
named by the folder (``push_cube`` -> ``push_cube/train_config.json``). A checkpoint name is a file's
stem under ``rlchain/checkpoints/`` (``cartpole``). A path that exists is used as given; a path that
starts with ``rlchain/`` and does not exist here is looked up in the installed package, so the
commands the docs show from a clone's root work from any folder.
"""

from __future__ import annotations

import os

from rlchain.config.errors import ConfigError
from rlchain.errors import did_you_mean

PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # .../rlchain
CONFIGS_DIR = os.path.join(PACKAGE_DIR, "configs")
CHECKPOINTS_DIR = os.path.join(PACKAGE_DIR, "checkpoints")
CONFIG_EXTENSIONS = (".yaml", ".yml", ".json")


def _config_files() -> list[str]:
    """Every config file under rlchain/configs/, as a path relative to it with '/' separators."""
    found = []
    for folder, _, files in os.walk(CONFIGS_DIR):
        for name in files:
            if name.endswith(CONFIG_EXTENSIONS):
                found.append(os.path.relpath(os.path.join(folder, name), CONFIGS_DIR).replace(os.sep, "/"))
    return sorted(found)


def config_names() -> dict[str, str]:
    """Short name -> absolute path of every packaged config (the module docstring says how names are made)."""
    files = _config_files()
    names = {os.path.splitext(rel)[0]: rel for rel in files}
    stems: dict[str, list[str]] = {}
    folders: dict[str, list[str]] = {}
    for rel in files:
        stems.setdefault(os.path.splitext(os.path.basename(rel))[0], []).append(rel)
        if "/" in rel:
            folders.setdefault(rel.rsplit("/", 1)[0], []).append(rel)
    for stem, rels in stems.items():
        if len(rels) == 1 and stem not in names:
            names[stem] = rels[0]
    for folder, rels in folders.items():
        if len(rels) == 1 and folder not in names:
            names[folder] = rels[0]
    return {name: os.path.join(CONFIGS_DIR, *rel.split("/")) for name, rel in sorted(names.items())}


def checkpoint_names() -> dict[str, str]:
    """Short name -> absolute path of every packaged checkpoint (``cartpole`` -> .../checkpoints/cartpole.pth)."""
    if not os.path.isdir(CHECKPOINTS_DIR):
        return {}
    return {os.path.splitext(name)[0]: os.path.join(CHECKPOINTS_DIR, name)
            for name in sorted(os.listdir(CHECKPOINTS_DIR)) if name.endswith(".pth")}


def _in_package(path: str) -> str | None:
    """``rlchain/...`` read against the installed package, when that file exists there; ``nn/...`` is read
    as ``rlchain/checkpoints/...``, what the clone's ``nn`` link points to (the README's ``nn/cartpole.pth``
    then works from an installed wheel, and where git checks the link out as a plain file, as on Windows)."""
    parts = path.replace("\\", "/").split("/")
    if len(parts) > 1 and parts[0] == "nn":
        parts = ["rlchain", "checkpoints", *parts[1:]]
    if len(parts) > 1 and parts[0] == "rlchain":
        candidate = os.path.join(PACKAGE_DIR, *parts[1:])
        if os.path.isfile(candidate):
            return candidate
    return None


def resolve_config(name_or_path: str) -> str:
    """The config file ``name_or_path`` means: an existing path as given, else a packaged config.

    Neither is a one-line ConfigError that names the closest packaged names.
    """
    if os.path.isfile(name_or_path):
        return name_or_path
    found = _in_package(name_or_path)
    names = config_names()
    if found is None:
        key = name_or_path[:-len(".yaml")] if name_or_path.endswith(".yaml") else name_or_path
        found = names.get(key.replace("\\", "/"))
    if found is not None:
        return found
    stem = os.path.splitext(os.path.basename(name_or_path))[0]
    hint = did_you_mean(stem, names) or did_you_mean(name_or_path, names)
    raise ConfigError(name_or_path, "", f"config file not found, and no packaged config has that name{hint} "
                                        f"(`rlchain list` names them all)")


def resolve_checkpoint(name_or_path: str) -> tuple[str, bool]:
    """The checkpoint ``name_or_path`` means and whether it is a packaged one.

    An existing path is used as given; else ``rlchain/checkpoints/<x>.pth`` (or ``nn/<x>.pth``) or a
    packaged name (``cartpole``); else the argument unchanged, for the checkpoint loader to report as not found.
    """
    if os.path.isfile(name_or_path):
        return name_or_path, False
    found = _in_package(name_or_path)
    if found is None:
        found = checkpoint_names().get(name_or_path[:-len(".pth")] if name_or_path.endswith(".pth")
                                       else name_or_path)
    return (found, True) if found is not None else (name_or_path, False)
