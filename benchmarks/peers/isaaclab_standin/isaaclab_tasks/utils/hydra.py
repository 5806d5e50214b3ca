"""``hydra_task_config``: the task's env and agent configs, with ``agent.a.b=value`` / ``env.a=value``
overrides from the command line (the part of Isaac Lab's Hydra use its rl_games train.py relies on)."""

import functools
import sys

import yaml

from isaaclab_tasks.utils import load_cfg_from_registry


def _set(target, dotted: str, value) -> None:
    *path, last = dotted.split(".")
    for key in path:
        target = target[key] if isinstance(target, dict) else getattr(target, key)
    if isinstance(target, dict):
        target[last] = value
    else:
        setattr(target, last, value)


def hydra_task_config(task_name: str, agent_cfg_entry_point: str):
    def decorator(func):
        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            env_cfg = load_cfg_from_registry(task_name, "env_cfg_entry_point")
            agent_cfg = load_cfg_from_registry(task_name, agent_cfg_entry_point)
            for arg in sys.argv[1:]:
                key, _, raw = arg.partition("=")
                root, _, dotted = key.partition(".")
                _set(agent_cfg if root == "agent" else env_cfg, dotted, yaml.safe_load(raw))
            return func(env_cfg, agent_cfg, *args, **kwargs)

        return wrapper

    return decorator
