"""Small things RLlib's doc pages use: ``AlgorithmConfig.overrides`` (advanced-API page's evaluation config) and
the one line a page's import the face does not offer ends in (single-agent-episode page)."""

import importlib

import pytest

from rlchain.rllib import alias
from rlchain.rllib.__main__ import explain
from rlchain.rllib.algorithms.algorithm_config import AlgorithmConfig
from rlchain.rllib.algorithms.ppo import PPOConfig


def test_overrides_checks_the_keys_and_gives_a_dict():
    assert AlgorithmConfig.overrides(explore=False) == {"explore": False}
    assert PPOConfig.overrides(lambda_=0.95, **{"lambda": 0.9}) == {"lambda_": 0.9}
    with pytest.raises(KeyError, match="Invalid property name clip_parm for config class PPOConfig.*clip_param"):
        PPOConfig.overrides(clip_parm=0.2)
    config = PPOConfig().evaluation(evaluation_config=AlgorithmConfig.overrides(explore=False))
    assert config["evaluation_config"] == {"explore": False}


@pytest.mark.parametrize("module, says", [
    ("ray.rllib.env.single_agent_episode", "get_observations(-1)"),
    ("ray.rllib.env.apis.task_settable_env", "foreach_env_runner"),
    ("ray.rllib.env.single_agent_env_runner", "algo.env_runner"),
])
def test_a_page_import_the_face_does_not_offer_is_one_line_naming_what_to_use(module, says):
    line = refused_import_line(module)
    assert line is not None and "\n" not in line and says in line


def refused_import_line(module: str) -> str | None:
    """The one line ``python -m rlchain.rllib`` prints for importing ``module`` under the face (it must refuse)."""
    alias.install()
    try:
        with pytest.raises(ImportError) as info:
            importlib.import_module(module)
    finally:
        alias.uninstall()
    return explain(info.value)


def test_a_learner_class_is_refused_in_one_line():
    from rlchain.rllib.face_error import FaceNotOffered
    with pytest.raises(FaceNotOffered) as info:
        PPOConfig().get_default_learner_class()
    line = explain(info.value)
    assert "\n" not in line and "build_algo().train()" in line



def test_async_vectorization_is_rlchains_async_vector_env():
    import gymnasium as gym

    from rlchain.rllib.algorithm import vector_env_type
    mode = gym.envs.registration.VectorizeMode
    assert vector_env_type(mode.ASYNC, "auto") == "async" == vector_env_type("async", "sync")
    assert vector_env_type(mode.SYNC, "auto") is None and vector_env_type(None, "auto") is None
    assert vector_env_type(mode.ASYNC, "RAY") is None  # Ray env runners step their own envs
