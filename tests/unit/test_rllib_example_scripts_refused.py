"""What RLlib's example scripts import and the face does not offer ends in one line naming what to use instead
(rlchain/rllib/alias.py's INSTEAD, run through ``python -m rlchain.rllib``'s explain)."""

import pytest

from tests.unit.test_rllib_doc_pages import refused_import_line


@pytest.mark.parametrize("module, says", [
    ("ray.rllib.env.wrappers.atari_wrappers", "AtariPreprocessing"),  # custom_cnn_rl_module.py
    ("ray.rllib.env.vector.vector_multi_agent_env", "gymnasium VectorEnv"),  # env_rendering_and_recording.py
    ("ray.rllib.core.learner.learner", "Learner subclasses are not run"),  # ppo_with_torch_lr_schedulers.py
    ("ray.rllib.core.learner.torch.torch_learner", "Learner subclasses are not run"),  # shared_encoder_cartpole.py
    ("ray.rllib.models.torch.misc", "model_config"),  # tiny_atari_cnn_rlm.py
])
def test_an_example_scripts_import_the_face_does_not_offer_is_one_line(module, says):
    line = refused_import_line(module)
    assert line is not None and "\n" not in line and says in line


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
