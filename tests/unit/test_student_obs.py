"""rlchain/algos/distill/student_obs.py on Dict observations kept per key: the student's view corrupted (float
keys only: an image stays uint8), delayed key by key, and stored per key (stacked, side by side, env rows)."""

import torch

from rlchain.algos.distill.student_obs import (
    DelayLine,
    cat_envs,
    corrupt,
    env_rows,
    merge_steps,
    stack_steps,
)
from rlchain.envs.obs_dict import ObsDict


def obs(t: float, n: int = 2) -> ObsDict:
    return ObsDict({"image": torch.full((n, 1, 4, 4), int(t), dtype=torch.uint8),
                    "proprio": torch.full((n, 3), float(t))})


def test_corrupting_a_dict_touches_the_float_keys_only():
    o = obs(5, 500)
    noisy = corrupt(o, 0.1, 0.2)
    assert noisy["image"] is o["image"] and noisy["image"].dtype == torch.uint8
    assert float((noisy["proprio"] == 0).float().mean()) > 0.1 and not torch.equal(noisy["proprio"], o["proprio"])
    assert corrupt(o, 0.0, 0.0) is o


def test_the_delay_line_delays_every_key():
    line = DelayLine(1)
    starts = torch.tensor([True, True])
    first = line.push(obs(1), starts)
    second = line.push(obs(2), ~starts)
    assert int(first["image"][0, 0, 0, 0]) == 1 and int(second["image"][0, 0, 0, 0]) == 1
    assert float(second["proprio"][1, 0]) == 1.0 and second["image"].dtype == torch.uint8


def test_stored_per_key_in_their_dtypes():
    steps = stack_steps([obs(t) for t in range(3)])  # (T=3, N=2)
    assert steps.shape == (3, 2) and steps["image"].dtype == torch.uint8 and steps["image"].shape == (3, 2, 1, 4, 4)
    both = cat_envs([steps, steps])
    assert both.shape == (3, 4) and both["proprio"].shape == (3, 4, 3)
    rows = env_rows(both, torch.tensor([3, 0]))  # env 3's rollout, then env 0's
    assert rows.shape == (6,) and rows["proprio"][:, 0].tolist() == [0.0, 1.0, 2.0, 0.0, 1.0, 2.0]
    assert merge_steps(steps)["image"].shape == (6, 1, 4, 4)
    flat = torch.zeros(3, 2, 5)
    assert stack_steps([flat[0], flat[1]]).shape == (2, 2, 5) and env_rows(flat, torch.tensor([1])).shape == (3, 5)
