"""EmbodiChain's benchmark protocol (rlchain/compare/protocol.py) by hand."""

import math

import pytest

from rlchain.compare.benchmark import markdown
from rlchain.compare.protocol import aggregate, first_sustained, leaderboard, stable


def test_stable_is_the_mean_of_the_last_three_finite_values():
    assert stable([0.1, 0.2, 0.4, 0.6, 0.8]) == pytest.approx(0.6)
    assert stable([0.5, math.nan]) == 0.5 and stable([]) is None


def test_steps_to_threshold_is_the_first_of_three_consecutive_hits():
    xs = [100, 200, 300, 400, 500, 600]
    assert first_sustained(xs, [0.7, 0.9, 0.5, 0.8, 0.8, 0.9], 0.8) == 400
    assert first_sustained(xs, [0.9, 0.9, 0.5, 0.9, 0.9, 0.1], 0.8) is None
    assert first_sustained(xs[:1], [0.9], 0.8, sustain=1) == 100


def runs():
    return [{"task": "push", "algorithm": "ppo", "final_success_rate_stable": s, "steps_to_success_threshold": st,
             "training_fps": 100.0} for s, st in ((0.9, 1000), (0.7, None), (0.8, 2000))] + \
           [{"task": "push", "algorithm": "grpo", "final_success_rate_stable": 0.95, "steps_to_success_threshold": 500}]


def test_aggregate_mean_std_iqm_and_reached_count():
    rows = {r["algorithm"]: r for r in aggregate(runs())}
    ppo = rows["ppo"]
    assert ppo["num_runs"] == 3 and ppo["runs_reaching_threshold"] == 2
    assert ppo["final_success_rate_stable_mean"] == pytest.approx(0.8)
    assert ppo["final_success_rate_stable_std"] == pytest.approx(math.sqrt(0.02 / 3))
    assert ppo["steps_to_success_threshold_mean"] == 1500
    assert ppo["stable_success_iqm_low"] <= ppo["stable_success_iqm"] <= ppo["stable_success_iqm_high"]


def test_leaderboard_ranks_by_stable_success_and_report_renders():
    rows = aggregate(runs())
    board = leaderboard(rows)
    assert [(b["rank"], b["algorithm"]) for b in board] == [(1, "grpo"), (2, "ppo")]
    text = markdown(rows, board, {"push": 0.6})
    assert "| push | ppo | 3 | 0.6 | 0.80 ± 0.08 |" in text and "| 1 | grpo | 0.95 |" in text


def test_peak_memory_on_a_cpu_run_is_the_resident_set(tmp_path, monkeypatch):
    import json

    from rlchain.compare import peak_memory
    from rlchain.compare.benchmark import memory_record

    out = tmp_path / "peaks.json"
    monkeypatch.setattr("sys.argv", ["x"])
    assert peak_memory.main([str(out), "--", "list"]) == 0  # runs `rlchain list` in this process
    peaks = json.loads(out.read_text())
    assert peaks["cpu_peak_rss_mb"] > 10 and peaks["gpu_peak_memory_mb"] is None
    record = memory_record(peaks)
    assert record["peak_memory_kind"] == "cpu_rss" and record["peak_memory_mb"] == peaks["cpu_peak_rss_mb"]
    assert memory_record({"cpu_peak_rss_mb": 900.0, "gpu_peak_memory_mb": 12.5})["peak_memory_mb"] == 12.5
    rows = aggregate([{**r, **record} for r in runs()])
    assert rows[1]["peak_memory_kind"] == "cpu_rss"
    assert f"| {rows[1]['peak_memory_mb_mean']:,.0f} RSS |" in markdown(rows, leaderboard(rows), {"push": 0.6})


@pytest.mark.skipif(not __import__("torch").cuda.is_available(), reason="needs CUDA")
def test_peak_memory_on_cuda_is_the_gpu_allocation():
    import torch

    from rlchain.compare.peak_memory import gpu_peak_mb

    block = torch.empty(64 * 2**20, dtype=torch.uint8, device="cuda")  # 64 MB
    assert gpu_peak_mb() >= 64
    del block
