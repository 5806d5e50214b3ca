"""rl_games' ``common.experience.VectorizedReplayBuffer`` on rlchain (rlchain/rl_games/common/experience.py), and
the one-line ImportError of an rl_games module rlchain does not offer when imported with ``from package import``."""

import pytest
import torch

from rlchain.rl_games.algos_torch import torch_ext  # noqa: F401  (the package imports as usual)
from rlchain.rl_games.common.experience import VectorizedReplayBuffer
from rlchain.rl_games.common.pbt import PbtCfg


def rows(start, n, obs_dim=3):
    """n transitions whose observation is the row number (start, start+1, ...)."""
    obs = torch.arange(start, start + n, dtype=torch.float32)[:, None].repeat(1, obs_dim)
    return obs, -obs[:, :2], obs[:, :1] * 10, obs + 0.5, (obs[:, :1] % 2 == 1)


def test_add_writes_rows_in_order_and_sample_returns_six_tensors():
    buf = VectorizedReplayBuffer((3,), (2,), capacity=8, device="cpu")
    buf.add(*rows(0, 3))
    assert buf.idx == 3 and not buf.full and len(buf) == 3
    assert buf.obses[:3, 0].tolist() == [0.0, 1.0, 2.0] and not buf.truncated.any()  # truncated defaults False
    obs, actions, rewards, next_obs, dones, truncated = buf.sample(16)
    assert obs.shape == (16, 3) and actions.shape == (16, 2) and rewards.shape == dones.shape == (16, 1)
    assert set(obs[:, 0].tolist()) <= {0.0, 1.0, 2.0}  # only rows written are drawn
    torch.testing.assert_close(next_obs, obs + 0.5)
    assert truncated.dtype == torch.bool and dones.dtype == torch.bool


def test_wrapping_overwrites_the_oldest_and_marks_full():
    buf = VectorizedReplayBuffer((3,), (2,), capacity=5, device="cpu")
    buf.add(*rows(0, 4))
    buf.add(*rows(4, 3), truncated=torch.ones(3, 1, dtype=torch.bool))
    assert buf.full and buf.idx == 2
    assert buf.obses[:, 0].tolist() == [5.0, 6.0, 2.0, 3.0, 4.0]
    assert buf.truncated[:, 0].tolist() == [True, True, False, False, True]


def test_a_batch_larger_than_the_buffer_keeps_the_newest_rows():
    buf = VectorizedReplayBuffer((3,), (2,), capacity=4, device="cpu")
    buf.add(*rows(0, 1))
    buf.add(*rows(1, 6))  # rows 1..6 from idx 1: 7 written in all, the last 4 kept
    assert buf.full and buf.idx == 7 % 4
    assert sorted(buf.obses[:, 0].tolist()) == [3.0, 4.0, 5.0, 6.0]
    assert buf.obses[(buf.idx - 1) % 4, 0] == 6.0  # the newest sits just before idx


def test_an_empty_add_changes_nothing_and_sampling_an_empty_buffer_is_an_error():
    buf = VectorizedReplayBuffer((3,), (2,), capacity=4, device="cpu")
    buf.add(*(t[:0] for t in rows(0, 1)))
    assert buf.idx == 0 and not buf.full
    with pytest.raises(RuntimeError, match="empty"):  # rl_games 2.0: a RuntimeError too
        buf.sample(2)


def test_state_dict_round_trips_and_reads_a_state_without_truncated():
    buf = VectorizedReplayBuffer((3,), (2,), capacity=4, device="cpu")
    buf.add(*rows(0, 3), truncated=torch.ones(3, 1, dtype=torch.bool))
    state = buf.state_dict()
    assert set(state) == {"obses", "next_obses", "actions", "rewards", "dones", "truncated", "idx", "full"}
    other = VectorizedReplayBuffer((3,), (2,), capacity=4, device="cpu")
    other.load_state_dict(state)
    assert other.idx == 3 and torch.equal(other.obses, buf.obses) and other.truncated[:3].all()
    del state["truncated"]
    other.load_state_dict(state)
    assert not other.truncated.any()


@pytest.mark.parametrize(("package", "name", "says"), [
    ("rlchain.rl_games.algos_torch", "sac_agent", "rl_games.algos_torch.sac_agent (SACAgent) is rl_games' agent code"),
    ("rlchain.rl_games.common", "a2c_common", "rl_games.common.a2c_common"),
    ("rlchain.rl_games.common.pbt", "pbt_utils", "Ray Tune's PBT"),
    ("rlchain.rl_games.common.experience", "ExperienceBuffer", "rollout storage of rl_games' PPO agents"),
])
def test_from_package_import_of_a_module_not_offered_is_one_line(package, name, says):
    with pytest.raises(ImportError, match="not offered by rlchain") as err:
        exec(f"from {package} import {name}")
    assert says in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(ImportError, match="cannot import name"):  # any other name stays Python's message
        exec(f"from {package} import no_such_name")


def test_pbt_cfg_takes_a_list_change_range_and_the_launcher():
    cfg = PbtCfg(change_range=[1.2, 1.8], launcher="/opt/isaac/python.sh")
    assert cfg.change_range == (1.2, 1.8) and cfg.launcher == "/opt/isaac/python.sh"
    assert PbtCfg.from_dict({"change_range": [1.1, 1.5]}).change_range == (1.1, 1.5)
