"""Learning tier (slow): every learning test trains on one torch thread, rollout and update (tests/conftest.py
pins it), so its same-seed result does not follow the machine's load and two run side by side (pytest -n 2)."""

import pytest
import torch

import rlchain.runner

pytestmark = pytest.mark.slow


def test_a_learning_test_gets_one_thread_when_its_config_names_none():
    plan = rlchain.runner.set_threads(None, None, "cpu")
    assert (plan.rollout, plan.update) == (1, 1), plan
    assert torch.get_num_threads() == 1


def test_a_config_that_names_its_threads_keeps_them():
    plan = rlchain.runner.set_threads(1, 2, "cpu")
    assert plan.update == min(2, plan.cores), plan
