"""SB3's policy argument and ``policy_kwargs`` that need users' own classes -> the ``sb3_policy`` network block.

``CnnPolicy``, a policy class (an ``ActorCriticPolicy`` subclass), a ``features_extractor_class`` (with its
``features_extractor_kwargs``), ``share_features_extractor``, ``normalize_images``, or a SAC ``net_arch`` with
different ``pi`` and ``qf`` sizes: these build :mod:`rlchain.networks.sb3_policy`'s network, the classes written
by name (:mod:`rlchain.networks.user_classes`), so the config stays data. Anything else keeps rlchain's built-in
network (:mod:`rlchain.sb3.keys` maps its ``policy_kwargs``).
"""

from __future__ import annotations

from typing import Any

from rlchain.networks.user_classes import remember

EXTRACTOR_KEYS = ("features_extractor_class", "features_extractor_kwargs", "share_features_extractor",
                  "normalize_images")
PPO_POLICY_KEYS = ("ortho_init", "log_std_init")
REFUSED = {"optimizer_class": "rlchain's algorithms own their optimizer (Adam); its settings are config keys",
           "optimizer_kwargs": "rlchain's algorithms own their optimizer (Adam); its settings are config keys",
           "use_expln": "state-dependent exploration is not in rlchain", "full_std": "gSDE is not in rlchain",
           "n_critics": "rlchain's SAC has two critics", "squash_output": "gSDE is not in rlchain"}
SAC_LOG_STD_BOUNDS = [-20.0, 2.0]  # SB3's actor clamps its log-std to these


def needs_sb3_network(algo: str, policy: Any, policy_kwargs: dict[str, Any]) -> bool:
    """Whether ``policy`` / ``policy_kwargs`` need the ``sb3_policy`` network (see the module docstring)."""
    if not isinstance(policy, str) or policy == "CnnPolicy":
        return True
    if any(key in policy_kwargs for key in (*EXTRACTOR_KEYS, *REFUSED)):  # REFUSED: its message says why
        return True
    arch = policy_kwargs.get("net_arch")
    return algo == "sac" and isinstance(arch, dict) and list(arch.get("pi", [])) != list(arch.get("qf", []))


def _data(key: str, value: Any) -> Any:
    """``value`` as plain data (a class or a function in it is a ValueError naming ``key``)."""
    if isinstance(value, dict):
        return {str(k): _data(f"{key}.{k}", v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_data(key, v) for v in value]
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise ValueError(f"policy_kwargs.{key}: {value!r} is not plain data (numbers, strings, lists, dicts)")


def sb3_network_block(algo: str, policy: Any, policy_kwargs: dict[str, Any]) -> dict[str, Any]:
    """The ``sb3_policy`` network block of ``algo`` (ppo, sac, dqn) for ``policy`` (a name or a class) and
    ``policy_kwargs``; a ValueError naming the key for what does not map."""
    if not isinstance(policy, str) and algo != "ppo":
        raise ValueError(f"policy: a policy class is taken for PPO (an ActorCriticPolicy subclass); {algo.upper()} "
                         f"takes 'MlpPolicy', 'CnnPolicy' or 'MultiInputPolicy' with policy_kwargs")
    kwargs: dict[str, Any] = {}
    for key, value in policy_kwargs.items():
        if key in REFUSED:
            raise ValueError(f"policy_kwargs.{key}: has no rlchain counterpart: {REFUSED[key]}")
        if key == "features_extractor_class":
            kwargs[key] = remember(value)
        elif key == "activation_fn":
            kwargs[key] = value if isinstance(value, str) else getattr(value, "__name__", repr(value))
        elif key in PPO_POLICY_KEYS and algo != "ppo":
            raise ValueError(f"policy_kwargs.{key}: a PPO policy argument; {algo.upper()}'s policy takes net_arch, "
                             f"activation_fn, {', '.join(EXTRACTOR_KEYS)}")
        else:
            kwargs[key] = _data(key, value)
    cnn = policy == "CnnPolicy" and "features_extractor_class" not in kwargs
    if cnn:
        kwargs["features_extractor_class"] = "NatureCNN"
    if "net_arch" not in kwargs and algo != "sac" and (cnn or kwargs.get("features_extractor_class") == "NatureCNN"):
        kwargs["net_arch"] = []  # SB3: NatureCNN's features go straight to the heads
    block: dict[str, Any] = {"name": "sb3_policy", "algo": algo,
                             "policy_class": None if isinstance(policy, str) else remember(policy),
                             "policy_kwargs": kwargs}
    if algo == "sac":
        block["log_std_bounds"] = list(SAC_LOG_STD_BOUNDS)
    if algo == "dqn":
        block["dueling"] = False  # SB3's Q-network has no dueling head
    return block


def stored_policy_kwargs(policy_kwargs: dict[str, Any]) -> dict[str, Any]:
    """``policy_kwargs`` with classes by name (what a saved model keeps)."""
    out = dict(policy_kwargs)
    if isinstance(out.get("features_extractor_class"), type):
        out["features_extractor_class"] = remember(out["features_extractor_class"])
    return out
