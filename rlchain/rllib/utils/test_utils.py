"""``ray.rllib.utils.test_utils``: RLlib's older home of the example-script helpers."""

from rlchain.rllib.examples.utils import add_rllib_example_script_args, run_rllib_example_script_experiment

__all__ = ["add_rllib_example_script_args", "run_rllib_example_script_experiment"]
