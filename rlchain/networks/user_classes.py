"""Users' own classes named in a config: a feature extractor or a policy class, stored by name, never imported.

A model's config is data (``model.save_config`` writes it, ``save`` stores it), so an SB3 argument that is a class
(``features_extractor_class=CustomCNN``, a policy class) is written as its name, ``module.QualName``. A name
is turned back into a class only from the classes this process already holds: those the SB3 face was given
(:func:`remember`) and the subclasses of the extractor and policy bases (rlchain's and, when the script imported
it, Stable-Baselines3's) that the running code defined. A file can name a class; it can never make rlchain import
a module.
"""

from __future__ import annotations

import sys
from typing import Any

_CLASSES: dict[str, type] = {}

BASES = (("rlchain.networks.sb3_extractors", "BaseFeaturesExtractor"),
         ("rlchain.networks.sb3_policies", "ActorCriticPolicy"),
         ("stable_baselines3.common.torch_layers", "BaseFeaturesExtractor"),
         ("stable_baselines3.common.policies", "BasePolicy"))
"""The base classes whose subclasses (already defined in this process) a stored name may resolve to."""


def class_name(cls: type) -> str:
    """``module.QualName`` of ``cls``."""
    return f"{cls.__module__}.{cls.__qualname__}"


def remember(value: Any) -> str:
    """The name of the class ``value`` (kept, so the name resolves back to it in this process); a string is a
    name already and passes through."""
    if isinstance(value, str):
        return value
    if not isinstance(value, type):
        raise ValueError(f"expected a class, got {value!r}")
    name = class_name(value)
    _CLASSES[name] = value
    return name


def _subclasses(base: type) -> list[type]:
    out, todo = [], [base]
    while todo:
        cls = todo.pop()
        out.append(cls)
        todo.extend(cls.__subclasses__())
    return out


def resolve(name: str, key: str) -> type:
    """The class named ``name`` among those this process holds; ``key`` names the config key in the error."""
    if name in _CLASSES:
        return _CLASSES[name]
    for module, attr in BASES:
        base = getattr(sys.modules.get(module), attr, None)
        if base is None:
            continue
        for cls in _subclasses(base):
            if class_name(cls) == name:
                _CLASSES[name] = cls
                return cls
    raise ValueError(f"{key}: class '{name}' is not defined in this process; define or import it before building "
                     f"the model (or pass it again: policy_kwargs=dict(...) to load) - rlchain never imports a "
                     f"module a config or a file names")
