"""RLlib's ``env_to_module_connector`` on the face (rlchain.rllib.obs_filter): ``MeanStdFilter()`` is rlchain's
observation normalizer, ``FlattenObservations()`` adds nothing (the face's observations are flat); any other
connector, another algorithm or non-default filter settings are one line."""

import gymnasium as gym
import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib import translate
from rlchain.rllib.algorithms.dqn import DQNConfig
from rlchain.rllib.algorithms.ppo import PPOConfig
from rlchain.rllib.connectors.env_to_module import FlattenObservations, MeanStdFilter
from rlchain.rllib.obs_filter import filter_keys


def _train(config):
    return translate.ppo_config(config, "Pendulum-v1", True, {})["params"]["config"]


def test_mean_std_filter_is_the_observation_normalizer():
    plain = _train(PPOConfig().environment("Pendulum-v1"))
    assert plain["normalize_input"] is False and "obs_normalizer_update" not in plain
    for make in (lambda env, spaces, device: MeanStdFilter(), lambda env: [MeanStdFilter()]):
        train = _train(PPOConfig().environment("Pendulum-v1").env_runners(env_to_module_connector=make))
        assert (train["normalize_input"], train["obs_normalizer"], train["obs_normalizer_update"]) == \
            (True, "rl_games", "step")


def test_other_connectors_and_settings_are_one_line():
    class Flatten:
        pass

    cases = [(PPOConfig().env_runners(env_to_module_connector=lambda env, spaces, device: Flatten()),
              "maps only MeanStdFilter"),
             (PPOConfig().env_runners(env_to_module_connector=lambda e, s, d: MeanStdFilter(update_stats=False)),
              "only its defaults"),
             (DQNConfig().env_runners(env_to_module_connector=lambda e, s, d: MeanStdFilter()),
              "PPO, APPO and IMPALA, not DQN"),
             (PPOConfig().env_runners(env_to_module_connector=lambda e, s, d: 1 / 0), "ZeroDivisionError")]
    for config, message in cases:
        with pytest.raises(ConfigError, match=f"env_to_module_connector.*{message}") as info:
            config.validate()
        assert "\n" not in str(info.value)


def test_flatten_observations_adds_no_key_alone_or_beside_the_filter():
    from rlchain.rllib.connectors.env_to_module.flatten_observations import FlattenObservations as by_module
    assert by_module is FlattenObservations  # RLlib's examples import it from either path
    alone = PPOConfig().env_runners(env_to_module_connector=lambda e, s, d: FlattenObservations(multi_agent=True))
    assert filter_keys(alone) == {}
    assert _train(alone)["normalize_input"] is False
    both = PPOConfig().env_runners(env_to_module_connector=lambda e, s, d: [FlattenObservations(), MeanStdFilter()])
    assert filter_keys(both)["normalize_input"] is True
    dqn = DQNConfig().env_runners(env_to_module_connector=lambda e, s, d: FlattenObservations(agent_ids={"a"}))
    assert filter_keys(dqn) == {}  # the PPO / APPO / IMPALA rule is MeanStdFilter's


def test_another_connector_name_is_a_one_line_import_error():
    from rlchain.rllib.alias import FaceImportError
    with pytest.raises(FaceImportError, match="only MeanStdFilter and FlattenObservations"):
        from rlchain.rllib.connectors.env_to_module import NumpyToTensor  # noqa: F401


def test_any_other_missing_name_is_an_attribute_error_so_pickles_module_search_passes_over_it():
    import pickle

    import rlchain.rllib.connectors.env_to_module as connectors
    assert not hasattr(connectors, "torch") and getattr(connectors, "Foo", None) is None
    pickle.whichmodule(object(), "torch")  # torch.compile's cache key runs this search over every loaded module
    with pytest.raises(ImportError, match="cannot import name"):
        from rlchain.rllib.connectors.env_to_module import MeanStdFiltr  # noqa: F401


def test_a_multi_agent_mean_std_filter_normalizes_per_policy_each_rollout():
    # multi_agent_pendulum_ppo.py: MeanStdFilter(multi_agent=True); rlchain's multi-policy PPO keeps each policy's
    # statistics and folds a rollout in before its update (its multi_agent refuses obs_normalizer_update: step)
    config = PPOConfig().env_runners(env_to_module_connector=lambda e, s, d: MeanStdFilter(multi_agent=True))
    keys = filter_keys(config)
    assert keys["normalize_input"] is True and keys["obs_normalizer_update"] == "auto"
    assert filter_keys(PPOConfig().env_runners(
        env_to_module_connector=lambda e, s, d: MeanStdFilter()))["obs_normalizer_update"] == "step"


def test_mean_std_filter_under_impala_and_appo_is_the_learners_normalizer():
    # cartpole_impala.py sets MeanStdFilter(); rlchain's V-trace learner folds each batch into the statistics
    from rlchain.rllib.algorithms.appo import APPOConfig
    from rlchain.rllib.algorithms.impala import IMPALAConfig
    from rlchain.rllib.algorithms.impala.translate import vtrace_config
    for cls in (IMPALAConfig, APPOConfig):
        config = cls().environment("CartPole-v1").env_runners(env_to_module_connector=lambda e, s, d: MeanStdFilter())
        obs = gym.spaces.Box(-1.0, 1.0, (4,))
        train = vtrace_config(config, "CartPole-v1", obs, False, {})["params"]["config"]
        assert train["normalize_input"] is True and "obs_normalizer_update" not in train
        plain = vtrace_config(cls().environment("CartPole-v1"), "CartPole-v1", obs, False, {})["params"]["config"]
        assert plain["normalize_input"] is False
