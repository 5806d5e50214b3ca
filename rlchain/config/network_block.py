"""``params.network`` (and any network block inside the config) -> its typed dataclass, and the lookups
and checks every config block shares: a registered name, a planned key left at its default."""

from __future__ import annotations

import dataclasses
from typing import Any

from rlchain.config import compat
from rlchain.config.errors import ConfigError
from rlchain.config.fields import parse_dataclass
from rlchain.config.multi_input import InputConfig, MultiInputNetworkConfig
from rlchain.config.network import NetworkConfig, ResnetNetworkConfig
from rlchain.registry import network_config_class


def parse_network(network: Any, source: str, path: str = "params.network") -> Any:
    """Built-in builders get a typed NetworkConfig; user builders may declare ``config_class`` (a class
    attribute, or ``register_network(..., config_class=...)``)."""

    if network is None:
        network = {}
    if not isinstance(network, dict):
        raise ConfigError(source, path, f"expected a mapping, got {network!r}")
    network = compat.translate_network(network, source, path)
    name = network.get("name", "actor_critic")
    if not isinstance(name, str):
        raise ConfigError(source, f"{path}.name", f"expected a network name (a string), got {name!r}")
    config_class = network_config_class(name)
    if config_class is None:
        return network
    parsed = parse_dataclass(config_class, network, path, source)
    if isinstance(parsed, MultiInputNetworkConfig):  # each key's encoder block, typed
        inputs = {str(k): parse_dataclass(InputConfig, {} if v is None else v, f"{path}.inputs.{k}", source)
                  for k, v in parsed.inputs.items()}
        parsed = dataclasses.replace(parsed, inputs=inputs)
        for key in ("cnn", "critic_mlp"):
            if getattr(parsed, key) is not None:
                raise ConfigError(source, f"{path}.{key}", f"not used by multi_input (each observation key's encoder "
                                                           f"is in {path}.inputs); remove it")
    check_planned(parsed, path, source)
    if isinstance(parsed, (NetworkConfig, ResnetNetworkConfig)):
        chosen = [k for k in ("discrete", "multi_discrete", "continuous")
                  if getattr(parsed.space, k) is not None]
        if len(chosen) > 1:
            raise ConfigError(source, f"{path}.space", f"choose one action head, got {', '.join(chosen)}")
    if getattr(parsed, "history", None) is not None and parsed.rnn is not None:
        raise ConfigError(source, f"{path}.history", "choose rnn or history, not both")
    if getattr(parsed, "critic_mlp", None) is not None and not parsed.separate:
        raise ConfigError(source, f"{path}.critic_mlp", "a critic of its own needs separate: True")
    return parsed


def network_name(network: Any) -> str:
    """The registered builder name of a parsed network block (a dataclass or a user's dict; none: actor_critic)."""
    return network.name if hasattr(network, "name") else (network or {}).get("name", "actor_critic")


def has_rnn(network: Any) -> bool:
    """Whether a parsed network block is one of rlchain's with an ``rnn`` block."""
    return isinstance(network, (NetworkConfig, ResnetNetworkConfig)) and \
        (network.rnn is not None or getattr(network, "history", None) is not None)


def check_registered(registry: Any, name: str, path: str, source: str) -> None:
    """``name`` must be in ``registry``: a ConfigError at ``path`` with a did-you-mean otherwise."""
    if name not in registry:
        raise ConfigError(source, path, registry.unknown_message(name))


def check_planned(obj: Any, path: str, source: str) -> None:
    """A key whose feature is not implemented yet may only hold its default value."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        status = f.metadata.get("status", "yes")
        if status.startswith("planned"):
            default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
            if value != default and value not in (None, False, {}):
                raise ConfigError(source, f"{path}.{f.name}",
                                  f"not implemented in rlchain yet ({status}); remove the key or set it "
                                  f"to {default!r}")
        elif dataclasses.is_dataclass(value):
            check_planned(value, f"{path}.{f.name}", source)
