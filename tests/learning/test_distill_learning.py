"""Learning tier (slow): the LSTM student of distill_cartpole_lstm.yaml, which sees the cart position and the
pole angle only, reaches at least 90 % of its teacher's return (nn/cartpole.pth, PPO on the full state),
both played alone, deterministic, 20 games each."""

import glob
import os

import pytest

from rlchain import Runner
from rlchain.inference.player import Player
from tests.conftest import CONFIGS, ROOT

pytestmark = pytest.mark.slow


def played(params, checkpoint):
    player = Player(params, checkpoint)
    try:
        return player.play(games=20, deterministic=True, quiet=True).mean_reward
    finally:
        player.close()


def test_lstm_student_reaches_90_percent_of_the_mlp_teacher(tmp_path):
    teacher_path = os.path.join(ROOT, "nn", "cartpole.pth")
    runner = Runner().load(os.path.join(CONFIGS, "distill_cartpole_lstm.yaml"), [
        f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
        f"params.config.teacher_checkpoint={teacher_path}", "params.config.full_experiment_name=null",
        "params.torch_threads=1"])
    result = runner.train()
    student = played(runner.params, glob.glob(str(tmp_path / "runs" / "*" / "nn" / "distill_cartpole_lstm.pth"))[0])
    teacher = played(Runner().load(os.path.join(CONFIGS, "ppo_cartpole.yaml")).params, teacher_path)
    assert teacher >= 475, teacher
    assert student >= 0.9 * teacher, (student, teacher, result)
