"""What RLlib's example scripts import and the face does not offer ends in one line naming what to use instead
(rlchain/rllib/alias.py's INSTEAD, run through ``python -m rlchain.rllib``'s explain)."""

import pytest

from rlchain.config.errors import ConfigError
from rlchain.rllib.algorithms.algorithm import Algorithm
from rlchain.rllib.algorithms.algorithm_config import AlgorithmConfig
from tests.unit.test_rllib_doc_pages import refused_import_line


@pytest.mark.parametrize("module, says", [
    ("ray.rllib.env.wrappers.atari_wrappers", "AtariPreprocessing"),  # custom_cnn_rl_module.py
    ("ray.rllib.env.vector.vector_multi_agent_env", "gymnasium VectorEnv"),  # env_rendering_and_recording.py
    ("ray.rllib.core.learner.learner", "Learner subclasses are not run"),  # ppo_with_torch_lr_schedulers.py
    ("ray.rllib.core.learner.torch.torch_learner", "Learner subclasses are not run"),  # shared_encoder_cartpole.py
    ("ray.rllib.models.torch.misc", "model_config"),  # tiny_atari_cnn_rlm.py
    ("ray.rllib.connectors.env_to_module.frame_stacking", "FrameStackObservation"),  # algorithms/ppo/atari_ppo.py
    ("ray.rllib.connectors.learner.frame_stacking", "FrameStackObservation"),  # algorithms/dqn/atari_dqn.py
    ("ray.rllib.connectors.module_to_env", "preprocess in a gymnasium wrapper"),  # the general connectors line
    ("ray.rllib.core.distribution.torch.torch_distribution", "rlchain's categorical"),  # actions/custom_action_...
    ("ray.rllib.algorithms.cql", "offline RL is not in rlchain"),  # algorithms/cql/pendulum_cql.py
    ("ray.rllib.algorithms.bc.bc", "offline RL is not in rlchain"),  # algorithms/bc/cartpole_bc.py
    ("ray.rllib.algorithms.dreamerv3", "the face trains PPO, APPO, IMPALA, DQN and SAC"),  # algorithms/dreamerv3/
    ("ray.rllib.algorithms.tqc", "SACConfig"),  # algorithms/tqc/pendulum_tqc.py
    ("ray.rllib.algorithms.ppo.torch.ppo_torch_learner", "Learner subclasses are not run"),  # ppo_with_custom_loss_fn
    ("ray.rllib.env.utils", "wrap a game as a MultiAgentEnv"),  # multi_agent/self_play_with_open_spiel.py
    ("ray.rllib.core.rl_module.marl_module", "multi_rl_module"),  # multi_agent/restore_1_of_n_agents_from_...
    ("ray.rllib.utils.metrics.learner_info", "LEARNER_RESULTS"),  # debugging/deterministic_training.py
    ("ray.rllib.env.external.env_runner_server_for_external_inference", "gymnasium env class"),  # envs/env_conn...
])
def test_an_example_scripts_import_the_face_does_not_offer_is_one_line(module, says):
    line = refused_import_line(module)
    assert line is not None and "\n" not in line and says in line


def test_an_example_class_newer_than_the_installed_rllib_says_so():
    # a module RLlib's repository has but its 2.60 package does not (actions/action_masking_for_off_policy_...)
    from rlchain.rllib.examples import installed_rllib_version
    line = refused_import_line("ray.rllib.examples.envs.classes.no_such_example_env")
    assert line is not None and "\n" not in line
    if installed_rllib_version() is None:
        assert "none is installed" in line
    else:
        assert f"installed RLlib ({installed_rllib_version()})" in line and "newer" in line


def test_an_example_module_an_older_rllib_kept_outside_classes_says_where_it_is_now():
    # envs/memory_leaking_env.py (an older layout): from ray.rllib.examples.envs.random_env import RandomEnv
    from rlchain.rllib.examples import installed_rllib_version
    if installed_rllib_version() is None:
        pytest.skip("RLlib is not installed beside the face")
    line = refused_import_line("ray.rllib.examples.envs.random_env")
    assert line is not None and "\n" not in line
    assert "has it as ray.rllib.examples.envs.classes.random_env" in line and "older" in line


@pytest.mark.parametrize("statement, says", [
    ("from ray.rllib.algorithms.dqn import DQNTorchPolicy", "the old Policy API"),  # multi_agent/two_algorithms.py
    ("from ray.rllib.algorithms.ppo import PPOTorchPolicy", "the old Policy API"),
    ("from ray.rllib.core import NO_SUCH_NAME", "see docs/rllib.md"),
])
def test_a_name_the_faces_module_lacks_is_one_line_in_the_scripts_names(statement, says):
    from rlchain.rllib import alias
    from rlchain.rllib.__main__ import explain
    alias.install()
    try:
        with pytest.raises(ImportError) as info:
            exec(statement, {})
    finally:
        alias.uninstall()
    line = explain(info.value)
    module, name = statement.split()[1], statement.split()[3]
    assert line is not None and "\n" not in line and says in line
    assert line.startswith(f"ImportError: {module} has no {name}") and "rlchain.rllib" not in line


def test_an_import_refused_inside_rllibs_example_module_names_that_module():
    # rl_modules/migrate_modelv2_*.py import ModelV2ToRLModule, whose module imports core.distribution
    from rlchain.rllib.examples import installed_rllib_version
    if installed_rllib_version() is None:
        pytest.skip("RLlib is not installed beside the face")
    line = refused_import_line("ray.rllib.examples.rl_modules.classes.modelv2_to_rlm")
    assert line is not None and "\n" not in line and line.startswith("ImportError: ray.rllib.core.distribution")
    assert line.endswith("(imported by RLlib's example module ray.rllib.examples.rl_modules.classes.modelv2_to_rlm)")
    assert "imported by" not in refused_import_line("ray.rllib.core.distribution")  # the script's own import


def test_an_offered_algorithms_missing_module_is_not_called_another_algorithm():
    from rlchain.rllib.alias import instead
    assert "not in rlchain" not in instead("ray.rllib.algorithms.ppo.no_such_module")


@pytest.mark.parametrize("name", ["ppo", "appo", "impala", "dqn", "sac"])
def test_the_algorithms_own_module_path_imports_the_faces_classes(name):
    # pendulum_sac.py: from ray.rllib.algorithms.sac.sac import SACConfig
    import importlib

    from rlchain.rllib import alias
    alias.install()
    try:
        inner = importlib.import_module(f"ray.rllib.algorithms.{name}.{name}")
        outer = importlib.import_module(f"ray.rllib.algorithms.{name}")
    finally:
        alias.uninstall()
    cls = f"{name.upper()}Config"
    assert getattr(inner, cls) is getattr(outer, cls) and inner.__name__.startswith("rlchain.rllib")


def test_columns_import_from_core_as_rllibs_examples_do():
    # rl_modules/classes/autoregressive_actions_rlm.py: from ray.rllib.core import Columns
    from rlchain.rllib.core import Columns
    from rlchain.rllib.core.columns import Columns as by_module
    assert Columns is by_module and Columns.ACTION_DIST_INPUTS == "action_dist_inputs"


def test_rllibs_stats_classes_are_refused_in_one_line_naming_the_reduce_kinds():
    line = refused_import_line("ray.rllib.utils.metrics.stats.ema")  # clearing_ema.py, persistent_ema.py
    assert line is not None and "\n" not in line and "reduce='ema'" in line
    from rlchain.rllib.__main__ import explain
    from rlchain.rllib.face_error import FaceImportError
    with pytest.raises(FaceImportError) as info:
        from rlchain.rllib.utils.metrics.metrics_logger import DEFAULT_STATS_CLS_LOOKUP  # noqa: F401
    assert "\n" not in explain(info.value) and "log_value" in explain(info.value)


def test_the_names_rllibs_evaluation_and_fault_tolerance_examples_import_are_there():
    from rlchain.rllib.env.env_runner_group import EnvRunnerGroup
    from rlchain.rllib.env_runner_group import EnvRunnerGroup as Face
    from rlchain.rllib.utils.error import EnvError
    assert EnvRunnerGroup is Face and issubclass(EnvError, Exception)


def test_a_custom_algorithms_own_config_key_says_the_face_does_not_run_new_algorithms():
    # algorithms/vpg_custom_algorithm.py: VPGConfig(AlgorithmConfig) sets num_episodes_per_train_batch in __init__
    class VPG(Algorithm):
        pass

    class VPGConfig(AlgorithmConfig):
        def __init__(self):
            super().__init__(algo_class=VPG)
            self.num_episodes_per_train_batch = 10

    with pytest.raises(ConfigError) as err:
        VPGConfig()
    line = str(err.value)
    assert "\n" not in line and "VPGConfig" in line and "num_episodes_per_train_batch" in line
    assert "new Algorithm (VPG" in line and "PPOConfig()" in line
