"""rl_games 2.0's normalize_rms_advantage (moving advantage statistics) and SAC's mixed_precision."""

import copy
import logging

import pytest
import torch

from rlchain.algos.core import precision
from rlchain.algos.core.advantage_stats import MovingAdvantageStats
from rlchain.config import ConfigError, parse_params
from tests.conftest import BASE


def test_moving_statistics_by_hand():
    stats = MovingAdvantageStats(decay=0.5)
    a = torch.tensor([1.0, 3.0])  # mean 2, mean square 5
    out = stats.normalize(a)
    mean, sqrs = 0.5 * 2.0, 0.5 * 5.0  # from zero, no bias correction (rl_games' mean_std)
    std = (sqrs - mean ** 2) ** 0.5
    assert torch.allclose(out, (a - mean) / std)
    b = torch.tensor([-2.0, 0.0])  # mean -1, mean square 2
    out = stats.normalize(b)
    mean, sqrs = 0.5 * mean + 0.5 * -1.0, 0.5 * sqrs + 0.5 * 2.0
    assert torch.allclose(out, ((b - mean) / (sqrs - mean ** 2) ** 0.5).clamp(-5, 5))
    frozen = stats.normalize(b, update=False)
    assert torch.allclose(frozen, out) and stats.step == 3
    flat = MovingAdvantageStats(0.5)
    flat.normalize(torch.zeros(4))  # variance floored at 1e-10, the output clipped to +-5
    assert flat.normalize(torch.ones(4), update=False).max() == 5.0


def test_state_round_trips_with_rl_games_names():
    stats = MovingAdvantageStats(decay=0.9)
    stats.normalize(torch.randn(64))
    state = stats.state_dict()
    assert set(state) == {"step", "mean", "sqrs"} and state["mean"].shape == (1,)
    other = MovingAdvantageStats(decay=0.9)
    other.load_state_dict(state)
    x = torch.randn(8)
    assert torch.equal(other.normalize(x, update=False), stats.normalize(x, update=False))


def _cfg(**config):
    cfg = copy.deepcopy(BASE)
    cfg["params"]["config"].update(config)
    return cfg


def test_rms_advantage_keys_parse_and_reject_a_wrong_momentum():
    parsed = parse_params(_cfg(normalize_rms_advantage=True, adv_rms_momentum=0.9), "cfg.yaml").config
    assert parsed.normalize_rms_advantage and parsed.adv_rms_momentum == 0.9
    with pytest.raises(ConfigError, match=r"params\.config\.adv_rms_momentum: .*expected 0 <= adv_rms_momentum < 1"):
        parse_params(_cfg(adv_rms_momentum=1.5), "cfg.yaml")


def test_ppo_agent_normalizes_by_the_moving_statistics_and_checkpoints_them(tmp_path):
    from rlchain import Runner

    runner = Runner().load(_cfg(normalize_rms_advantage=True, adv_rms_momentum=0.5, max_epochs=2,
                                train_dir=str(tmp_path), save_best_after=0))
    result = runner.train()
    from rlchain.runs import checkpoint as ckpt

    state = ckpt.load(f"{result.run_dir}/nn/last_{runner.params.config.name}.pth")
    stats = state["agent"]["advantage_mean_std"]
    assert int(stats["step"]) == 3 and float(stats["sqrs"]) > 0  # two epochs folded in


def test_sac_mixed_precision_warns_once_and_runs_float32_on_a_cpu(monkeypatch, caplog):
    monkeypatch.setattr(precision, "_warned", set())
    with caplog.at_level(logging.WARNING, logger="rlchain"):
        assert precision.sac_autocast_dtype(True, torch.device("cpu")) is None
        assert precision.sac_autocast_dtype(True, torch.device("cpu")) is None
    assert sum("SAC autocasts to bfloat16 on CUDA GPUs only" in r.getMessage() for r in caplog.records) == 1
    assert precision.sac_autocast_dtype(False, torch.device("cuda")) is None


@pytest.mark.skipif(not torch.cuda.is_available() or not torch.cuda.is_bf16_supported(), reason="needs a bf16 GPU")
def test_sac_mixed_precision_autocasts_bf16_on_cuda():
    assert precision.sac_autocast_dtype(True, torch.device("cuda")) is torch.bfloat16
