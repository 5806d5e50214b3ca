"""Configuration: YAML/JSON files parsed once into typed dataclasses (params.py: the whole params block)."""

from rlchain.config.errors import ConfigError
from rlchain.config.load import load_config, load_raw, parse_params
from rlchain.config.params import Params

__all__ = ["ConfigError", "Params", "load_config", "load_raw", "parse_params"]
