"""The files of the face's checkpoint folder (``save_to_path``): rlchain's checkpoint, the RLlib config as JSON
data and the rlchain YAML; RLlib's own checkpoints (pickles) are recognised and refused, never unpickled."""

from __future__ import annotations

import json
import os
from types import SimpleNamespace
from typing import Any

from rlchain.config.errors import ConfigError
from rlchain.config.text import read_data
from rlchain.runs import checkpoint as ckpt

CHECKPOINT_FILE = "rlchain_checkpoint.pth"
CONFIG_FILE = "rllib_config.json"
RLCHAIN_CONFIG_FILE = "rlchain_config.yaml"
RLLIB_FILES = ("algorithm_state.pkl", "algorithm_state.msgpack", "rllib_checkpoint.json",
               "class_and_ctor_args.pkl", "policy_state.pkl", "module_state.pkl", "state.pkl")
"""Files of RLlib's own checkpoints (pickles): refused, never unpickled."""


class SavedCheckpoint:
    """What RLlib's older ``Algorithm.save()`` returns: ``checkpoint.path`` is the ``save_to_path`` folder."""

    def __init__(self, path: str) -> None:
        self.checkpoint = SimpleNamespace(path=path)


def checkpoint_path(path: Any) -> str:
    """The path a checkpoint argument names: a path, Ray Tune's ``Checkpoint`` (its ``path``) or what ``save()``
    returned (its ``checkpoint.path``, as RLlib's ``restore`` takes it)."""
    path = getattr(path, "checkpoint", path)
    return os.fspath(getattr(path, "path", path))


def checkpoint_file(path: Any) -> str:
    """The rlchain checkpoint of a folder written by ``save_to_path`` (or a ``.pth`` path); an RLlib checkpoint or
    anything else is a one-line CheckpointError."""
    path = checkpoint_path(path)
    if os.path.isfile(path):
        return path
    if not os.path.isdir(path):
        raise ckpt.CheckpointError(f"{path}: no such checkpoint folder")
    found = os.path.join(path, CHECKPOINT_FILE)
    if os.path.isfile(found):
        return found
    theirs = [name for name in RLLIB_FILES if os.path.exists(os.path.join(path, name))]
    if theirs or any(name.endswith(".pkl") for name in os.listdir(path)):
        raise ckpt.CheckpointError(f"{path}: an RLlib checkpoint ({(theirs or ['*.pkl'])[0]}): rlchain does not "
                                   f"unpickle RLlib's files; retrain with the face, or export the weights from "
                                   f"RLlib as a state_dict and load them as data")
    raise ckpt.CheckpointError(f"{path}: no {CHECKPOINT_FILE} (not written by save_to_path)")


def stored_config(folder: str) -> dict[str, Any]:
    """The folder's ``rllib_config.json`` (``{}`` when it has none) read as data: UTF-8 and nesting bounded
    (:func:`rlchain.config.text.read_data`), an object with ``algo`` a name, ``config`` an object and ``iteration``
    a count; anything else is a one-line ConfigError naming the file and the key."""
    path = os.path.join(os.fspath(folder), CONFIG_FILE)
    if not os.path.isfile(path):
        return {}
    data = read_data(path)
    if not isinstance(data, dict):
        raise ConfigError(path, "", f"expected a JSON object written by save_to_path, got {type(data).__name__}")
    for key, kind, what in (("algo", str, "an algorithm name"), ("config", dict, "an object of config keys"),
                            ("iteration", int, "a whole number")):
        if key in data and (not isinstance(data[key], kind) or isinstance(data[key], bool)):
            raise ConfigError(path, key, f"expected {what}, got {type(data[key]).__name__}")
    return data


def read_text(path: str) -> str:
    """A text file's content ('' when there is none)."""
    if not os.path.isfile(path):
        return ""
    with open(path) as f:
        return f.read()


def json_data(values: dict[str, Any]) -> dict[str, Any]:
    """The JSON-able part of a config dict (classes, functions and objects are left out)."""
    out = {}
    for key, value in values.items():
        try:
            json.dumps(value)
        except (TypeError, ValueError):
            continue
        out[key] = value
    return out
