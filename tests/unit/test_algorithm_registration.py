"""A built-in algorithm is one folder, one config class and one registration line: the config parser, the
docs generator (docs/config.md) and the layer test find a newly registered algorithm through the registry."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import pytest

import rlchain  # noqa: F401  (registers the built-ins)
from rlchain.algos.base.algorithm import AlgorithmBase
from rlchain.config.docs import render
from rlchain.config.errors import ConfigError
from rlchain.config.fields import option, positive
from rlchain.config.load import parse_params
from rlchain.config.run import RunConfig
from rlchain.registry import ALGOS, scoped_registrations
from tests.unit.test_import_layers import algo_families, layer_violation


@dataclass(frozen=True)
class EchoConfig(RunConfig):
    """``params.config`` of the test's algorithm."""

    doc_note: ClassVar[str] = "a test's algorithm"
    echo_gain: float = option(1.0, "how loud the echo is", check=positive)
    echo_steps: int = option(4, "steps per echo")

    def validate(self) -> tuple[str, str] | None:
        return ("echo_steps", "must divide num_actors") if self.num_actors % self.echo_steps else None


class Echo(AlgorithmBase):
    """The test's algorithm: registering it is all it takes."""

    config_class = EchoConfig


Echo.__module__ = "rlchain.algos.echo.algorithm"  # as if it lived in its own folder, rlchain/algos/echo/


def _raw(**config):
    return {"params": {"algo": {"name": "echo"}, "model": {"name": "discrete_a2c"},
                       "config": {"env_name": "CartPole-v1", "num_actors": 8, **config}}}


def test_the_parser_reads_its_config_class_and_runs_its_checks():
    with scoped_registrations():
        ALGOS.register("echo", Echo)
        params = parse_params(_raw(echo_gain=2.0), "echo.yaml")
        assert isinstance(params.config, EchoConfig) and params.config.echo_gain == 2.0
        with pytest.raises(ConfigError, match=r"echo.yaml.*params.config.echo_steps.*must divide num_actors"):
            parse_params(_raw(echo_steps=3), "echo.yaml")
        with pytest.raises(ConfigError, match="echo_gain"):
            parse_params(_raw(echo_gian=2.0), "echo.yaml")


def test_the_docs_list_a_registered_algorithm():
    with scoped_registrations():
        ALGOS.register("echo", Echo)
        text = render()
    assert "## params.config for algo echo (a test's algorithm)" in text
    section = text.split("## params.config for algo echo", 1)[1].split("\n## ", 1)[0]
    assert "| `echo_gain` |" in section and "| `echo_steps` |" in section and "| `env_name` |" in section
    assert "algo echo" not in render()  # gone with the registration


def test_the_layer_test_takes_a_registered_algorithm_as_a_family():
    with scoped_registrations():
        ALGOS.register("echo", Echo)
        families = algo_families(ALGOS)
    assert "rlchain.algos.echo" in families and "rlchain.algos.echo" not in algo_families(ALGOS)
    assert layer_violation("rlchain.algos.base.context", "rlchain.algos.echo.algorithm", families)
    assert layer_violation("rlchain.algos.echo.algorithm", "rlchain.training.loop", families)
    assert layer_violation("rlchain.training.loop", "rlchain.algos.echo.algorithm", families)
    assert layer_violation("rlchain.algos.echo.algorithm", "rlchain.runs.writers", families) is None
    assert layer_violation("rlchain.algos.echo.algorithm", "rlchain.runs.writers", algo_families(ALGOS))
