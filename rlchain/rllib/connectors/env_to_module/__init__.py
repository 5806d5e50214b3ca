"""``ray.rllib.connectors.env_to_module``: ``MeanStdFilter`` (rlchain's ``normalize_input``); any other name is a
one-line ImportError saying what to write instead."""

from typing import Any

from rlchain.rllib.connectors.env_to_module.mean_std_filter import MeanStdFilter

__all__ = ["MeanStdFilter"]


def __getattr__(name: str) -> Any:
    if name.startswith("__"):
        raise AttributeError(name)
    from rlchain.rllib.alias import FaceImportError
    raise FaceImportError(f"ray.rllib.connectors.env_to_module.{name} is not offered by rlchain's RLlib face: "
                          f"only MeanStdFilter is; preprocess observations in a gymnasium wrapper",
                          name="ray.rllib.connectors.env_to_module")
