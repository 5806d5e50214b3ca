"""The files of the face's checkpoint folder (``save_to_path``): rlchain's checkpoint, the RLlib config as JSON
data and the rlchain YAML; RLlib's own checkpoints (pickles) are recognised and refused, never unpickled."""

from __future__ import annotations

import json
import os
from typing import Any

from rlchain.runs import checkpoint as ckpt

CHECKPOINT_FILE = "rlchain_checkpoint.pth"
CONFIG_FILE = "rllib_config.json"
RLCHAIN_CONFIG_FILE = "rlchain_config.yaml"
RLLIB_FILES = ("algorithm_state.pkl", "algorithm_state.msgpack", "rllib_checkpoint.json",
               "class_and_ctor_args.pkl", "policy_state.pkl", "module_state.pkl", "state.pkl")
"""Files of RLlib's own checkpoints (pickles): refused, never unpickled."""


def checkpoint_file(path: Any) -> str:
    """The rlchain checkpoint of a folder written by ``save_to_path`` (or a ``.pth`` path); an RLlib checkpoint or
    anything else is a one-line CheckpointError."""
    path = os.fspath(getattr(path, "path", path))
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
