"""Learning tier (slow): GRPO learns two small tensor tasks, with and without shared group starts
(rlchain/configs/grpo_*.yaml; ~10-20 s each on one CPU thread)."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("shared", [False, True])
@pytest.mark.parametrize("config, check", [
    ("grpo_torch_cartpole.yaml", lambda r: r.mean_reward >= 195),
    ("grpo_point_mass.yaml", lambda r: r.stop_reason.startswith("success_to_win")),  # success rate >= 0.9
])
def test_grpo_learns(tmp_path, config, check, shared):
    overrides = [f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
                 "params.torch_threads=1", f"params.config.shared_starts={str(shared).lower()}"]
    result = Runner().load(os.path.join(CONFIGS, config), overrides).train()
    assert check(result), result
