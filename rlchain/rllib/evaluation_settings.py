"""RLlib 2.60's checks of the evaluation settings (``AlgorithmConfig._validate_evaluation_settings``), made when
the algorithm is built, as RLlib's ``validate()`` makes them; each refusal is one line (RLlib's is a ValueError,
so is the face's ConfigError).

- ``evaluation_parallel_to_training=True`` needs ``evaluation_num_env_runners > 0`` (RLlib's evaluation runs in
  parallel on its own env runners; the face has no such runners and evaluates after the ``train()``);
- ``evaluation_duration="auto"`` needs ``evaluation_parallel_to_training=True`` (RLlib sizes "auto" by the
  training step it runs beside);
- otherwise ``evaluation_duration`` is a whole number > 0.
"""

from __future__ import annotations

from typing import Any

from rlchain.config.errors import ConfigError


def check_evaluation(config: Any) -> None:
    """Refuse, in one line, the evaluation settings RLlib's validation refuses."""
    settings = config._settings
    where = type(config).__name__
    parallel = bool(settings.get("evaluation_parallel_to_training"))
    runners = settings.get("evaluation_num_env_runners") or 0
    if parallel and not runners:
        raise ConfigError(where, "evaluation_parallel_to_training",
                          "True needs evaluation_num_env_runners > 0, as RLlib's validation says: set "
                          ".evaluation(evaluation_num_env_runners=1) or evaluation_parallel_to_training=False")
    duration = settings.get("evaluation_duration", 10)
    if duration == "auto":
        if not parallel:
            raise ConfigError(where, "evaluation_duration", "'auto' needs evaluation_parallel_to_training=True "
                                                            "(and evaluation_num_env_runners > 0), as in RLlib: "
                                                            "give a number of episodes or timesteps")
    elif isinstance(duration, bool) or not isinstance(duration, int) or duration <= 0:
        raise ConfigError(where, "evaluation_duration", f"expected a whole number > 0 or 'auto', got {duration!r}")
