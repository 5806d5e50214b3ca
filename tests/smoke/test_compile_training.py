"""config.torch_compile through a real run: training works and the checkpoint plays uncompiled."""

import os

import pytest

from rlchain import Runner
from tests.conftest import CONFIGS

pytestmark = pytest.mark.smoke


@pytest.mark.parametrize("config", ["ppo_cartpole.yaml", "ppo_cartpole_masked_velocity_rnn.yaml"])
def test_torch_compile_eager_backend_trains_and_plays(tmp_path, config):
    path = os.path.join(CONFIGS, config)
    overrides = [f"params.config.train_dir={tmp_path}", "params.config.max_epochs=2", "params.config.print_stats=false",
                 "params.config.torch_compile={mode: default, backend: eager}", "params.config.save_best_after=0"]
    result = Runner().load(path, overrides).train()
    assert result.epoch == 2
    name = Runner().load(path).params.config.name
    played = Runner().load(path).play(os.path.join(result.run_dir, "nn", f"last_{name}.pth"), games=1, quiet=True)
    assert played.games == 1
