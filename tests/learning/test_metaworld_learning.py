"""Learning tier (slow): PPO on envpool's MetaWorld/Reach-v3 raises the success rate well above chance."""

import os
import time

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS


@pytest.mark.slow
def test_ppo_metaworld_reach_success_rate(tmp_path):
    """Threshold: a success rate of 0.3 over the last 32 episodes (MetaWorld's rule: ``info['success']``
    at any step of the 500-step episode) within 65536 frames. Uniformly random actions succeeded in 1 of
    32 measured episodes (0.03), so 0.3 is ten times chance; with seed 5 the config reached 0.38 at 53k
    frames and 0.47 at 84k. MetaWorld/Push-v3 (ppo_metaworld_push.yaml) needs millions of frames, far
    beyond this tier's budget: its config is smoke-tested in tests/smoke/test_push_cube.py instead."""
    pytest.importorskip("envpool")
    start = time.time()
    result = Runner().load(os.path.join(CONFIGS, "ppo_metaworld_reach.yaml"), [
        f"params.config.train_dir={tmp_path}", "params.config.print_stats=false",
        "params.config.max_frames=65536", "params.config.success_to_win=0.3"]).train()
    assert result.stop_reason == "success_to_win 0.3 reached", result
    print(f"PPO MetaWorld/Reach-v3: success 0.3 at {result.frames} frames in {time.time() - start:.0f} s")
