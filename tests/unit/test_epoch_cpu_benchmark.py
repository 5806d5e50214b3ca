"""benchmarks/epoch_cpu.py: one child's measurement, and a base tree that is not a checkout."""

import os
import sys

import pytest

from tests.conftest import ROOT

sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
epoch_cpu = pytest.importorskip("epoch_cpu")


@pytest.mark.smoke
def test_child_times_epochs_of_this_tree():
    row = epoch_cpu.child(ROOT, "torch:TorchCartPole-v0:64", ["params.config.mini_epochs=1"], warmup=0, epochs=1)
    assert row["tree"] == ROOT
    assert row["rollout_ms"] > 0 and row["update_ms"] > 0
    # 16 steps x 64 envs over the CPU seconds of both phases
    assert row["cpu_sps"] == pytest.approx(16 * 64 / ((row["rollout_ms"] + row["update_ms"]) / 1e3), rel=1e-6)


def test_a_base_tree_without_rlchain_is_a_one_line_error(tmp_path):
    with pytest.raises(SystemExit) as exc:
        epoch_cpu.main(["--base-tree", str(tmp_path), "--cases", "torch:TorchCartPole-v0:64"])
    message = str(exc.value)
    assert message.startswith(f"epoch_cpu.py: --base-tree {tmp_path}: no rlchain") and "\n" not in message
