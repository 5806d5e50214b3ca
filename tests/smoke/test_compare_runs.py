"""``rlchain compare`` on CartPole runs trained here: two configs, two seeds each, a couple of epochs
(a PNG and a Markdown table with IQM and intervals from real run folders)."""

import os

import pytest

from rlchain import Runner
from rlchain.compare import cli
from tests.conftest import CONFIGS
from tests.smoke.test_train_play_resume import small

pytestmark = pytest.mark.smoke
CARTPOLE = os.path.join(CONFIGS, "ppo_cartpole.yaml")


def test_compare_two_configs_two_seeds(tmp_path, capsys):
    for name, lr in (("ppo_a", "1e-3"), ("ppo_b", "3e-4")):
        for seed in (1, 2):
            Runner().load(CARTPOLE, small(tmp_path, epochs=3, extra=[
                f"params.config.name={name}", f"params.seed={seed}", f"params.config.learning_rate={lr}",
                "params.config.print_stats=false"])).train()
    out = str(tmp_path / "cmp")
    runs = str(tmp_path / "runs")
    assert cli.main([f"{runs}/ppo_a_*", f"{runs}/ppo_b_*", "--label-by", "config", "--out", out, "--reps", "300"]) == 0
    text = open(os.path.join(out, "compare.md")).read()
    assert "- **ppo_a**: 2 runs" in text and "- **ppo_b**: 2 runs" in text
    assert "### rewards/step" in text and "| at | ppo_a | ppo_b |" in text
    rows = [line for line in text.splitlines() if line.startswith("| ") and "frames |" in line]
    assert rows and all(line.count("(2/2)") == 2 for line in rows[-1:])  # every run reached the last point
    with open(os.path.join(out, "rewards_step.png"), "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    # an rlchain run logs no success rate for CartPole: asking for it is a one-line error naming the run
    capsys.readouterr()
    assert cli.main([runs, "--tag", "success", "--out", out, "--no-plot"]) == 2
    assert "no scalar 'episodes/success_rate'" in capsys.readouterr().err
