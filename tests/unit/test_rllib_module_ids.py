"""The face's default module id: one definition (``ray.rllib.core.DEFAULT_MODULE_ID``), the names RLlib gives it
elsewhere are the same object."""

import ast
import pathlib

import rlchain.rllib
from rlchain.rllib import core, results
from rlchain.rllib.policy import sample_batch


def test_default_module_id_is_defined_once():
    root = pathlib.Path(rlchain.rllib.__file__).parent
    where = [str(p.relative_to(root)) for p in sorted(root.rglob("*.py"))
             for node in ast.walk(ast.parse(p.read_text()))
             if isinstance(node, ast.Constant) and node.value == "default_policy"]
    assert where == ["core/__init__.py"], where
    assert sample_batch.DEFAULT_POLICY_ID is core.DEFAULT_MODULE_ID == "default_policy"
    assert core.DEFAULT_POLICY_ID is core.DEFAULT_MODULE_ID


def test_results_file_learners_under_the_default_module_id():
    class Report:
        mean_reward, mean_length, frames, seconds, stats = 1.0, 2.0, 8, 0.1, {}

    out = results.train_result(Report(), {"num_actors": 2, "horizon_length": 4}, iteration=1, time_total=0.1,
                               games=0, episode_custom={}, learner={"policy_loss": 0.5})
    assert out["learners"][core.DEFAULT_MODULE_ID]["policy_loss"] == 0.5
