"""``rlchain compare`` (rlchain/compare/) on run folders written here with rlchain's own TensorBoard writer:
grouping, tags, the IQM table, the PNGs, and one-line errors for bad input."""

import os
import sys
import time

import pytest
import yaml

from rlchain.compare import cli, runs
from rlchain.compare.runs import CompareError
from rlchain.runs.writers import TensorBoardWriter


def make_run(root, folder, rewards, config_name="cartpole", success=None, info=None, frames_per_epoch=1000):
    """A run folder as --train makes it: config.yaml and summaries/ events; epoch k (1-based) at k frames_per_epoch
    frames and k seconds after the writer opened."""
    path = os.path.join(root, folder)
    os.makedirs(os.path.join(path, "summaries"))
    with open(os.path.join(path, "config.yaml"), "w") as fh:
        yaml.safe_dump({"params": {"config": {"name": config_name}}}, fh)
    writer = TensorBoardWriter(os.path.join(path, "summaries"))
    start = time.time()
    for k, reward in enumerate(rewards, 1):
        scalars = {"rewards/step": reward, "losses/a_loss": 0.1}
        if success is not None:
            scalars["episodes/success_rate"] = success[k - 1]
        if info is not None:
            scalars["env_info/reward_box_target"] = info[k - 1]
        for tag, value in scalars.items():
            writer.call("add_scalar", tag, value, k * frames_per_epoch, walltime=start + k)
    writer.close()
    return path


@pytest.fixture
def two_groups(tmp_path):
    """Group ppo: 4 seeds with rewards 1, 2, 3, 100 at the last epoch; group sac: 2 seeds."""
    root = str(tmp_path / "runs")
    for seed, last in enumerate((1.0, 2.0, 3.0, 100.0)):
        make_run(root, f"ppo_26-07-00-0{seed}", [0.0, 0.5, last], "ppo", success=[0, 0.5, 1], info=[1, 2, 3])
    for seed, last in enumerate((10.0, 20.0)):
        make_run(root, f"sac_26-08-00-0{seed}", [5.0, 6.0, last], "sac", success=[0, 0, 1], info=[0, 0, 1])
    return root


def test_groups_by_name_config_glob_and_label(two_groups):
    root = two_groups
    by_name = runs.group_runs([root])
    assert [label for label, _ in by_name] == ["ppo"] * 4 + ["sac"] * 2
    assert [label for label, _ in runs.group_runs([os.path.join(root, "*")], "config")] == ["ppo"] * 4 + ["sac"] * 2
    by_glob = runs.group_runs([os.path.join(root, "s*"), os.path.join(root, "p*")], "glob")
    assert [label for label, _ in by_glob] == [os.path.join(root, "s*")] * 2 + [os.path.join(root, "p*")] * 4
    labelled = runs.group_runs([f"B={root}/sac_*", f"A={root}/ppo_26-07-00-00"])
    assert [label for label, _ in labelled] == ["B", "B", "A"]
    assert runs.name_label("runs/cartpole_26-06-35-10_4242") == "cartpole"


def test_curves_against_frames_and_seconds(two_groups):
    run = runs.load_runs([os.path.join(two_groups, "ppo_26-07-00-03")])[0]
    curve = run.curves["rewards/step"]
    assert list(curve.frames) == [1000, 2000, 3000]
    assert curve.seconds == pytest.approx([1, 2, 3], abs=0.2)  # from the writer's first event
    assert curve.value_at(2500) == 0.5 and curve.value_at(3000) == 100.0
    assert curve.value_at(500) is None and curve.value_at(3001) is None  # before the first, past the last
    assert curve.value_at(2.5, "seconds") == 0.5
    assert runs.resolve_tags([], [run]) == ["rewards/step", "episodes/success_rate", "env_info/reward_box_target"]
    assert runs.resolve_tags(["reward", "losses/a_loss"], [run]) == ["rewards/step", "losses/a_loss"]


def test_cli_writes_the_iqm_table_and_a_png_per_tag(two_groups, tmp_path, capsys):
    out = str(tmp_path / "cmp")
    points = ["--at-frames", "2k", "3000", "--at-seconds", "2.5", "--reps", "500"]
    assert cli.main([two_groups, "--out", out, *points]) == 0
    text = open(os.path.join(out, "compare.md")).read()
    assert text == capsys.readouterr().out
    assert "- **ppo**: 4 runs" in text and "- **sac**: 2 runs" in text
    assert "| at | ppo | sac |" in text
    # at 3000 frames: ppo's IQM of 1, 2, 3, 100 is 2.5; sac's of 10, 20 is 15; bootstrap bounds within the seeds
    row = next(line for line in text.splitlines() if line.startswith("| 3k frames |"))
    ppo, sac = (cell.strip() for cell in row.split("|")[2:4])
    assert ppo.startswith("2.5 [") and ppo.endswith("] (4/4)") and sac.startswith("15 [")
    low, high = (float(v) for v in ppo[ppo.index("[") + 1:ppo.index("]")].split(","))
    assert 1.0 <= low <= 2.5 <= high <= 100.0
    assert "| 2k frames | 0.5 [0.5, 0.5] (4/4) | 6 [6, 6] (2/2) |" in text
    assert "| 2.5 s | 0.5 [0.5, 0.5] (4/4) | 6 [6, 6] (2/2) |" in text
    assert "### episodes/success_rate" in text and "### env_info/reward_box_target" in text
    for name in ("rewards_step.png", "episodes_success_rate.png", "env_info_reward_box_target.png"):
        with open(os.path.join(out, name), "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    # the same seed, the same table
    assert cli.main([two_groups, "--out", out, *points, "--no-plot"]) == 0
    def tables(markdown):
        return [line for line in markdown.splitlines() if line.strip() and not line.startswith("![")]
    assert tables(open(os.path.join(out, "compare.md")).read()) == tables(text)


@pytest.mark.parametrize("argv, message", [
    (["{root}/nothing_*"], "matches no folder"),
    (["{root}/empty"], "no TensorBoard event files"),
    (["{root}", "--tag", "env_info/nope"], "no scalar 'env_info/nope' (it has: "),
    (["{root}", "--label-by", "colour"], "invalid choice"),
    (["{root}", "--at-frames", "lots"], "expected a number such as"),
])
def test_bad_input_is_one_line(two_groups, tmp_path, capsys, argv, message):
    os.makedirs(os.path.join(two_groups, "..", "empty"))
    root = os.path.join(two_groups, "..")
    argv = [a.replace("{root}", two_groups if "empty" not in a else root) for a in argv]
    assert cli.main([*argv, "--out", str(tmp_path / "cmp"), "--no-plot"]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1 and err.startswith("rlchain compare: error: ")


def test_missing_matplotlib_names_the_extra(two_groups, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    assert cli.main([two_groups, "--out", str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "rlchain compare: error: the plots need matplotlib: pip install 'rlchain[bench]' (or pass --no-plot)"
    with pytest.raises(CompareError, match="bench"):
        from rlchain.compare.plot import pyplot
        pyplot()


def test_amounts():
    assert cli.amount("500k") == 500_000 and cli.amount("1.5M") == 1_500_000 and cli.amount("5e5") == 500_000
    assert cli.amount("90") == 90.0
