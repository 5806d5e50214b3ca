"""Loading a saved SB3-style model as data: rlchain's model file, the ``.zip`` :meth:`BaseModel.save` writes, or
Stable-Baselines3's own archive; the file's names (an env id, classes) are looked up, never imported."""

from __future__ import annotations

import os
from typing import Any

from rlchain.config.stored import as_data
from rlchain.envs.known import GYM, check_listed
from rlchain.sb3 import files
from rlchain.sb3.envs import EnvSource, env_source, same_spaces
from rlchain.sb3.model_zip import format_system_info, has_model, read_model, saved_system_info, system_info
from rlchain.sb3.replay import ReplayBufferView
from rlchain.sb3.zip_format import is_sb3_archive, read_sb3_archive


class Spaces:
    """The observation and action spaces of the trained env: enough to build the policy network."""

    num_envs = 1

    def __init__(self, observation_space: Any, action_space: Any) -> None:
        self.observation_space = observation_space
        self.action_space = action_space



def model_file(path: str, must_exist: bool = True) -> str:
    """``path``, or ``path.zip`` when it has no extension, as SB3 adds it (loading finds ``path.zip``, then
    ``path.pth``, then ``path`` itself)."""
    path = os.fspath(path)
    if os.path.splitext(path)[1] or not must_exist:
        return path if os.path.splitext(path)[1] else path + ".zip"
    for candidate in (path + ".zip", path + ".pth", path):
        if os.path.exists(candidate):
            return candidate
    return path + ".zip"


def load_model(cls: type, path: str, env: Any, device: str, print_system_info: bool, kwargs: dict[str, Any]) -> Any:
    """:meth:`BaseModel.load`: the model ``cls`` of the file ``path`` (rlchain's model file, its ``.zip``, or SB3's
    archive, each read as data), on ``env`` (else the gymnasium id the file names, looked up, never imported)."""
    path = model_file(path)
    if print_system_info:
        saved = saved_system_info(path)
        print("== CURRENT SYSTEM INFO ==\n" + format_system_info(system_info()), flush=True)
        print("== SAVED MODEL SYSTEM INFO ==\n" + (saved or "(none stored in this file)\n"), flush=True)
    if has_model(path):
        state = read_model(path, lambda own: files.load_model(own, cls.algo))
    elif is_sb3_archive(path):
        return _load_archive(cls, path, env, device, kwargs)
    else:
        state = files.load_model(path, cls.algo)
    stored, _ = as_data(state["config"], path)  # no module, callback or trust named by the file
    if env is None and state["env_id"] is not None:  # a name from the file: looked up, never imported
        check_listed(state["env_id"], GYM, path, "env_id", "pass the env to load(path, env=...)")
    init = {"n_envs": kwargs.pop("n_envs", None) or state["n_envs"], "seed": state["seed"], "device": device,
            "policy_kwargs": state["policy_kwargs"], **state["hyperparameters"], **kwargs}
    with files.named_by(path):
        return _restore(cls, path, state.get("policy", "MlpPolicy"), env, state["env_id"], init, state["spaces"],
                            stored, state["model"], state["num_timesteps"])

def _load_archive(cls: type, path: str, env: Any, device: str, kwargs: dict[str, Any]) -> Any:
    """A model from Stable-Baselines3's ``.zip`` (read as data: :mod:`rlchain.sb3.zip_format`); SB3's own
    settings and the weights, to play, fine-tune (``env=``) or export."""
    archive = read_sb3_archive(path, cls.algo)
    init = {"n_envs": kwargs.pop("n_envs", None) or archive.n_envs, "seed": archive.seed, "device": device,
            "policy_kwargs": archive.policy_kwargs, **archive.hyperparameters, **kwargs}
    with files.named_by(path):
        return _restore(cls, path, "MlpPolicy", env, None, init, (archive.observation_space,
                            archive.action_space), None, archive.policy_state, archive.num_timesteps)

def _restore(cls: type, path: str, policy: str, env: Any, stored_env: Any, init: dict[str, Any], spaces: tuple,
             config: dict[str, Any] | None, weights: dict[str, Any], num_timesteps: int) -> Any:
    """The model of a loaded file: its arguments ``init``, ``spaces``, ``config`` (None: the one its arguments
    give) and ``weights``; trained further on ``env`` (else ``stored_env``), whose spaces must be the file's."""
    model = cls.__new__(cls)
    cls.__init__(model, policy, None, **init)  # PPO / SAC / DQN take BaseModel's arguments
    model._spaces = Spaces(*spaces)
    if config is None:
        model.env_source = EnvSource("sb3_archive", None, path)  # a config needs an env name
        config = model._config()
    model.env_source = None
    if env is not None or stored_env is not None:
        model.env_source, model._env_arg = env_source(env or stored_env, cls.algo), env or stored_env
        model.n_envs = model.env_source.num_envs or init["n_envs"]
        read = model._read_spaces() if env is not None else None
        if read is not None and not same_spaces(read, model._spaces):
            raise ValueError(f"{path}: the model's spaces {model._spaces.observation_space} / "
                             f"{model._spaces.action_space} are not {model.env_source.label}'s")
        if read is not None:
            model._spaces = read  # the env's own: a flattened Dict keeps its parts (predict takes the Dict)
    model._loaded_config = config
    model.policy = model._build_policy(config)
    files.load_into(model.policy, weights, path, "the network its spaces give")
    model.num_timesteps = num_timesteps
    model._weights_changed = True
    if cls.algo != "ppo":  # SB3's saved model holds no replay buffer: load_replay_buffer fills it
        model.replay_buffer = ReplayBufferView(model.config["params"]["config"]["replay_buffer_size"])
    return model
