"""``ray.rllib.examples``: the helpers RLlib's example scripts import (``examples.utils``).

When RLlib is installed beside the face, its own example classes (``ray.rllib.examples.envs.classes...``,
``ray.rllib.examples.rl_modules.classes...``: envs and modules written against RLlib's public API) are found under
this package too, so an example script that imports one runs unmodified; their ``ray.rllib`` imports resolve to
the face like the script's own. The face's modules come first (``examples.utils`` is always the face's).
"""

from __future__ import annotations

import importlib.util
import os


def _rllib_examples_dir() -> str | None:
    """The installed RLlib's ``examples`` folder (found on disk, without importing ``ray.rllib``), or None."""
    try:  # optional: ray
        spec = importlib.util.find_spec("ray")
    except (ImportError, ValueError):
        return None
    for root in (spec.submodule_search_locations or []) if spec is not None else []:
        folder = os.path.join(root, "rllib", "examples")
        if os.path.isdir(folder):
            return folder
    return None


_theirs = _rllib_examples_dir()
if _theirs is not None and _theirs not in __path__:
    __path__.append(_theirs)


def installed_rllib_version() -> str | None:
    """The version of the RLlib whose example classes this package reads (``ray``'s, from its metadata), or None."""
    if _theirs is None:
        return None
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("ray")
    except PackageNotFoundError:
        return "unknown version"


def example_in_classes(fullname: str) -> str | None:
    """Where the installed RLlib keeps the example module ``fullname`` (``ray.rllib.examples.envs.random_env``) in
    its ``classes`` folder (``ray.rllib.examples.envs.classes.random_env``), or None: older RLlib versions kept
    their example envs and modules one folder up, where older scripts still import them."""
    parts = fullname.split(".")
    if _theirs is None or parts[:3] != ["ray", "rllib", "examples"] or len(parts) < 5 or "classes" in parts:
        return None
    moved = [*parts[3:-1], "classes", parts[-1]]
    path = os.path.join(_theirs, *moved)
    if os.path.isfile(path + ".py") or os.path.isfile(os.path.join(path, "__init__.py")):
        return ".".join([*parts[:3], *moved])
    return None
