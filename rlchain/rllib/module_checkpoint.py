"""``RLModule.from_checkpoint(path)``: the trained module of a face checkpoint, for inference without the
algorithm (RLlib's deploy pattern: ``RLModule.from_checkpoint(ckpt / "learner_group" / "learner" /
"rl_module")["default_policy"]``).

``save_to_path`` writes RLlib's component folders (``learner_group/learner/rl_module/<module id>/``) beside its
files, each holding a small JSON that names the module; the weights stay in the one rlchain checkpoint at the
folder's root, read as data through rlchain's loader. The module is built from the checkpoint's stored config on
one env of the stored env name (the spaces), as the Player does.
"""

from __future__ import annotations

import json
import os
from typing import Any

import gymnasium as gym

from rlchain.config.errors import ConfigError
from rlchain.policy.load import load_policy
from rlchain.rllib.checkpoint_files import CHECKPOINT_FILE, CONFIG_FILE, RLCHAIN_CONFIG_FILE, read_text, stored_config
from rlchain.rllib.core import DEFAULT_MODULE_ID
from rlchain.rllib.envs import flat
from rlchain.rllib.module import NAME_PREFIX, RLModuleView
from rlchain.runner import Runner
from rlchain.runs import checkpoint as ckpt

MODULES_PATH = ("learner_group", "learner", "rl_module")
"""RLlib's component path from a checkpoint folder to its (multi-)module."""
MODULE_FILE = "rlchain_module.json"


def write_module_folders(root: str, module_ids: list[str]) -> None:
    """Create ``root/learner_group/learner/rl_module/<id>/`` for each module, each naming its module id (the
    weights stay in the root's one checkpoint)."""
    for module_id in module_ids:
        folder = os.path.join(root, *MODULES_PATH, module_id)
        os.makedirs(folder, exist_ok=True)
        with open(os.path.join(folder, MODULE_FILE), "w") as f:
            json.dump({"module_id": module_id}, f)


def locate(path: Any) -> tuple[str, str | None]:
    """(the checkpoint folder, the module id) of a path to ``.../rl_module`` (id None: every module) or to
    ``.../rl_module/<id>``; anything else is a one-line ConfigError."""
    given = os.path.abspath(os.fspath(getattr(path, "path", path)))
    parts = given.split(os.sep)
    for depth in (len(MODULES_PATH), len(MODULES_PATH) + 1):
        tail, root = parts[len(parts) - depth:], os.sep.join(parts[:len(parts) - depth]) or os.sep
        if tail[:len(MODULES_PATH)] == list(MODULES_PATH) and os.path.isfile(os.path.join(root, CONFIG_FILE)):
            module_id = tail[len(MODULES_PATH)] if depth > len(MODULES_PATH) else None
            if module_id is not None and not os.path.isfile(os.path.join(given, MODULE_FILE)):
                raise ConfigError(given, "module_id", f"'{module_id}' is not a module of this checkpoint "
                                                      f"({', '.join(module_ids(root)) or 'none'})")
            return root, module_id
    if os.path.isfile(os.path.join(given, CONFIG_FILE)):
        raise ConfigError(given, "path", "a whole checkpoint: pass its module folder, "
                                         f"{os.path.join(given, *MODULES_PATH)}, or use Algorithm.from_checkpoint")
    raise ConfigError(given, "path", f"not a module folder written by the face's save_to_path "
                                     f"(<checkpoint>/{'/'.join(MODULES_PATH)}[/<module id>]); RLlib's own checkpoints "
                                     f"are pickles, which rlchain does not load")


def module_ids(root: str) -> list[str]:
    folder = os.path.join(root, *MODULES_PATH)
    return sorted(n for n in os.listdir(folder) if os.path.isfile(os.path.join(folder, n, MODULE_FILE))) \
        if os.path.isdir(folder) else []


def from_checkpoint(path: Any) -> Any:
    """The module at ``path`` (an :class:`~rlchain.rllib.module.RLModuleView`), or ``{module id: module}`` for
    the ``rl_module`` folder itself."""
    root, module_id = locate(path)
    env = stored_config(root).get("config", {}).get("env")
    rlchain_yaml = read_text(os.path.join(root, RLCHAIN_CONFIG_FILE))
    instead = f"build your config, then algo.restore_from_path('{root}') and algo.get_module()"
    if not isinstance(env, str):
        raise ConfigError(root, "env", f"the checkpoint's env is not a name, so its spaces are unknown here: {instead}")
    if env not in gym.registry:  # a file's "module:Env" id would import that module in gym.make
        raise ConfigError(root, "env", f"'{env}' is not a registered gymnasium id (a checkpoint's env name is data, "
                                       f"never a module to import): {instead}")
    if NAME_PREFIX in rlchain_yaml:
        raise ConfigError(root, "rl_module_spec", f"the checkpoint trained an RLModule class, which is not in the "
                                                  f"JSON: {instead}")
    ids = module_ids(root)
    if ids != [DEFAULT_MODULE_ID]:
        raise ConfigError(root, "policies", f"a multi-agent checkpoint ({', '.join(ids)}): {instead}")
    checkpoint = os.path.join(root, CHECKPOINT_FILE)
    state = ckpt.load(checkpoint)  # read once: the stored config, then the weights
    params = Runner().load_from_checkpoint(checkpoint, state=state).params
    loaded = load_policy(params, checkpoint, num_envs=1, state=state)
    loaded.close()
    probe = flat(lambda index: gym.make(env))(0)  # the spaces the run's network saw (Discrete one-hot)
    try:
        view = RLModuleView(loaded.model, probe.observation_space, probe.action_space)
    finally:
        probe.close()
    return view if module_id is not None else {ids[0]: view}
