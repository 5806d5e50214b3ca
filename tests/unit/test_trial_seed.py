"""A Ray Tune trial's seed: the search's seed plus the trial's index, distinct for every trial."""

import pytest

from tests.conftest import installed

pytestmark = installed("ray")


@pytest.fixture
def trial_seed():
    """rlchain.tuning.trainable's trial_seed, imported when a test runs: the module imports ray.tune (seconds),
    which every pytest process would pay for when it collects this file."""
    from rlchain.tuning.trainable import TrialSetup, trial_seed

    return lambda seed, *ids: trial_seed(TrialSetup(base={}, overrides=[], keys=[], seed=seed), *ids)


def test_the_index_comes_from_rays_trial_folder(trial_seed):
    assert trial_seed(7, "3e5c299c", "RlchainTrainable_3e5c299c_4_params_config_learning_rate=0.0000_2026") == 11
    assert trial_seed(7, "3e5c299c", "RlchainTrainable_3e5c299c_12") == 19


def test_an_id_with_an_index_tail_and_hex_ids_without_a_folder(trial_seed):
    assert trial_seed(0, "exp_00003") == 3
    ids = ["609dd76d", "3e5c299c", "7675093c", "a1b2c3d4"]
    seeds = [trial_seed(5, i) for i in ids]
    assert len(set(seeds)) == len(ids)  # never one seed for every trial (Ray 2.x ids carry no index)
    assert seeds == [trial_seed(5, i) for i in ids]  # and stable for an id
