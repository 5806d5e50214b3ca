"""num_learners=2 under torchrun (rlchain/rllib/translate.py): two processes run the RLlib script unmodified on
rlchain's torch.distributed path, each sampling half the batch, their weights identical after every update.

The launch runs in the smoke tests' fork server (tests/smoke/cli_server.py): torchrun's own launcher, its workers
forks of it instead of new interpreters that import torch and rlchain (tests/smoke/test_distributed.py's way)."""

import os
import re
import sys

import pytest

from tests.smoke.cli_server import run_python

SCRIPT = os.path.join(os.path.dirname(__file__), "rllib_scripts", "two_learners.py")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.slow
def test_two_learners_train_data_parallel_under_torchrun(tmp_path):
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""), "OMP_NUM_THREADS": "1"}
    torchrun = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2"]
    out = run_python([*torchrun, "-m", "rlchain.rllib", SCRIPT], tmp_path, env, 300)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = re.findall(r"iteration 2 lifetime (\d+) weights (\S+)", out.stdout)
    assert len(lines) == 2, out.stdout  # one per learner process
    assert lines[0] == lines[1]  # the same weights on both: gradients averaged, parameters broadcast
    assert int(lines[0][0]) == 512  # two iterations of 256 env steps, 128 from each learner
