"""benchmarks/gpu/mjlab_time_to_reward.sh at tiny sizes on the CPU: rlchain and rsl_rl (mjlab's own train) on
Go1, one epoch of 4 envs each, a summary written. Skipped without mjlab (.ci/run's mjlab job runs it)."""

import os
import subprocess
import sys

import pytest

pytest.importorskip("mjlab")

from tests.conftest import ROOT  # noqa: E402

pytestmark = [pytest.mark.smoke, pytest.mark.mjlab]


def test_the_gpu_script_runs_tiny_on_the_cpu(tmp_path):
    env = {**os.environ, "PY": sys.executable, "DEVICE": "cpu", "ENVS": "4", "EPOCHS": "1",
           "TASKS": "ppo_go1_velocity", "OUT": str(tmp_path), "RL_GAMES_SRC": "", "OMP_NUM_THREADS": "1"}
    done = subprocess.run(["bash", os.path.join(ROOT, "benchmarks", "gpu", "mjlab_time_to_reward.sh")], env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    summary = (tmp_path / "summary.md").read_text()
    assert "| rlchain |" in summary and "| rsl_rl |" in summary
    assert (tmp_path / "ppo_go1_velocity" / "runs.json").is_file()
