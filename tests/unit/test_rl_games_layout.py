"""rl_games' checkpoint names and extra tags (rlchain.runs.rl_games_layout), as rl_games 1.6.5 / 2.0 write them."""

import math

from rlchain.runs.rl_games_layout import RlGamesTags, final_stem, periodic_stem
from rlchain.runs.run_dir import RunDir


def test_checkpoint_names_are_rl_games_ones():
    assert periodic_stem("cartpole_direct", 5, 33.878857) == "last_cartpole_direct_ep_5_rew_33.878857"
    assert final_stem("cartpole_direct", 10, 81.18142) == "last_cartpole_direct_ep_10_rew__81.18142_"
    assert final_stem("cartpole_direct", 1, None) == "last_cartpole_direct_ep_1_rew_-inf"
    run = RunDir("/r", "cartpole_direct", layout="rl_games")
    assert run.checkpoint("file:" + periodic_stem("cartpole_direct", 5, 2.5)) == \
        "/r/nn/last_cartpole_direct_ep_5_rew_2.5.pth"
    assert run.checkpoint("best") == "/r/nn/cartpole_direct.pth"


def test_extra_tags_shaped_rewards_only_for_an_affine_shaper():
    episodes = {"reward": 10.0, "length": 20.0}
    tags = RlGamesTags(e_clip=0.2, scale_value=0.1, shift_value=1.0, shaped=True).scalars(episodes, 500.0)
    assert math.isclose(tags["shaped_rewards/step"], 0.1 * (10.0 + 20.0))
    assert tags["performance/step_inference_fps"] == 500.0 and tags["info/e_clip"] == 0.2
    clipped = RlGamesTags(e_clip=None, scale_value=1.0, shift_value=0.0, shaped=False).scalars(episodes, 1.0)
    assert "shaped_rewards/step" not in clipped and "info/e_clip" not in clipped
