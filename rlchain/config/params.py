"""Typed configuration: every key of an rl_games ``params`` block, its default and its meaning.

Defaults live in the config classes once, each module one concept: :mod:`~rlchain.config.network`
(``params.network``), :mod:`~rlchain.config.run` (the keys every algorithm reads), :mod:`~rlchain.config.
actor_critic` (keys of the algorithms trained by the PPO agent), :mod:`~rlchain.config.ppo` (PPO),
:mod:`~rlchain.config.appo` (appo, impala), :mod:`~rlchain.config.off_policy` (sac, dqn). This module holds
the whole ``params`` block (:class:`Params`) that holds them.
``docs/config.md`` is generated from the docstrings (``python -m rlchain.config.docs``) and a test keeps it
in sync.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, TypeVar

from rlchain.config.errors import ConfigError
from rlchain.config.fields import option
from rlchain.config.run import RunConfig

__all__ = ["NamedBlock", "Params"]

C = TypeVar("C")


@dataclass(frozen=True)
class NamedBlock:
    """``params.algo`` / ``params.model``: a registered name."""

    name: str = option(doc="registered name")


@dataclass(frozen=True)
class Params:
    """The whole ``params`` block after parsing."""

    algo: NamedBlock
    model: NamedBlock
    config: RunConfig  # the algo's own class (PPOConfig, SACConfig, DQNConfig, APPOConfig, ...): see config_as
    network: Any = None  # NetworkConfig for built-in builders, the raw dict for user builders
    seed: int | None = None
    import_modules: list[str] | None = None
    torch_threads: int | None = None  # torch.set_num_threads for this process (rl_games key)
    update_threads: int | None = None  # CPU threads for the gradient updates (default: all cores, at most 4)
    malloc: str = "keep"  # glibc's malloc keeps freed memory (rlchain.parallel.memory), or "default"
    source: str = ""
    policies: dict[str, Params] | None = None  # config.multi_agent: each policy's own Params (load.py)

    def config_as(self, cls: type[C]) -> C:
        """``config`` as the class ``cls`` that the caller needs (e.g. PPO's :class:`PPOConfig`); a one-line
        :class:`ConfigError` naming the algo and both classes when this run's algorithm has another."""
        if isinstance(self.config, cls):
            return self.config
        raise ConfigError(self.source, "params.algo.name", f"algo {self.algo.name} configures a "
                          f"{type(self.config).__name__}; this needs a {cls.__name__} (the params.config of "
                          f"another algorithm)")

