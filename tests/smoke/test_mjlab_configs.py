"""rl_games 2.0's mjlab configs train as written (device cpu, a few envs) on the real mjlab tasks; the trained Go1
policy exports to ONNX. Skipped without mjlab (its own CI venv: .ci/run's mjlab job). Warp compiles each task's
kernels on first use (20-60 s on a CPU), cached in ~/.cache/warp after that."""

import os
import warnings

import pytest

pytest.importorskip("mjlab")

from rlchain import Runner  # noqa: E402
from tests.conftest import CONFIGS  # noqa: E402

pytestmark = [pytest.mark.smoke, pytest.mark.mjlab]
ENVS = 8  # x horizon_length 24 = a batch of 192


def small(tmp_path, epochs=2):
    return [f"params.config.train_dir={tmp_path}", "params.config.print_stats=false", "params.config.device=cpu",
            f"params.config.max_epochs={epochs}", f"params.config.num_actors={ENVS}",
            f"params.config.minibatch_size={ENVS * 24}",
            f"params.config.central_value_config.minibatch_size={ENVS * 24}",
            "params.config.env_config.device=cpu"]


@pytest.mark.parametrize("name", ["ppo_go1_velocity.yaml", "ppo_lift_cube_yam.yaml"])
def test_rl_games_mjlab_config_trains_as_written(tmp_path, name):
    path = os.path.join(CONFIGS, "rl_games", name)
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        runner = Runner().load(path, small(tmp_path))
        result = runner.train()
    assert result.epoch == 2
    last = os.path.join(result.run_dir, "nn", f"last_{runner.params.config.name}.pth")
    assert os.path.isfile(last)
    if name == "ppo_go1_velocity.yaml":  # the asymmetric critic read mjlab's critic group (72) beside the actor's (48)
        from rlchain.runs import checkpoint as ckpt

        state = ckpt.load(last)
        assert state["model"]["a2c_network.actor_mlp.0.weight"].shape[1] == 48
        assert state["central_value"]["a2c_network.actor_mlp.0.weight"].shape[1] == 72
        pytest.importorskip("onnxruntime")
        from rlchain.inference.export.onnx import export_onnx

        out = export_onnx(runner.params, last, str(tmp_path / "go1.onnx"))
        assert os.path.getsize(out) > 0
