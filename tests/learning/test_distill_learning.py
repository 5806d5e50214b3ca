"""Learning tier (slow): distilled students reach at least 90 % of their teacher's return, both played alone,
deterministic. CartPole: the LSTM student of distill_cartpole_lstm.yaml sees the cart position and the pole
angle only (teacher nn/cartpole.pth, PPO on the full state); the student plays 20 games to 450, 90 % of the most a
CartPole game scores (the teacher's 20 games are test_learning.py's: 475 or more). HalfCheetah: the LSTM student of
distill_halfcheetah_lstm.yaml sees the joint positions only, with sensor noise while training (teacher
rlchain/checkpoints/halfcheetah_teacher.pth, PPO on all 17 numbers; 2 games each). Pendulum: an MLP student of
distill_pendulum_sac.yaml fitted to a SAC teacher (nn/pendulum_sac.pth) reaches score_to_win."""

import glob
import os

import pytest

from rlchain import Runner
from rlchain.config.packaged import resolve_checkpoint
from rlchain.inference.player import Player
from tests.conftest import CONFIGS, ROOT

pytestmark = pytest.mark.slow


def played(params, checkpoint, games=20):
    player = Player(params, checkpoint)
    try:
        return player.play(games=games, deterministic=True, quiet=True).mean_reward
    finally:
        player.close()


def test_lstm_student_reaches_90_percent_of_the_mlp_teacher(tmp_path):
    teacher_path = resolve_checkpoint("cartpole")[0]
    runner = Runner().load(os.path.join(CONFIGS, "distill_cartpole_lstm.yaml"), [
        f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
        f"params.config.teacher_checkpoint={teacher_path}", "params.config.full_experiment_name=null",
        "params.torch_threads=1"])
    result = runner.train()
    student = played(runner.params, glob.glob(str(tmp_path / "runs" / "*" / "nn" / "distill_cartpole_lstm.pth"))[0])
    # the teacher is the shipped nn/cartpole.pth, which test_learning.py's test_shipped_checkpoints_play_to_score
    # plays to 475 or more over 20 games; CartPole's games end at 500, so 450 is 90 % of any teacher's score
    assert student >= 0.9 * 500, (student, result)


def test_halfcheetah_student_without_velocities_reaches_90_percent_of_the_teacher(tmp_path):
    pytest.importorskip("envpool")
    teacher_path = os.path.join(ROOT, "rlchain", "checkpoints", "halfcheetah_teacher.pth")
    teacher = played(Runner().load(os.path.join(CONFIGS, "ppo_halfcheetah.yaml")).params, teacher_path, games=2)
    assert teacher > 3000, teacher
    runner = Runner().load(os.path.join(CONFIGS, "distill_halfcheetah_lstm.yaml"), [
        f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
        f"params.config.teacher_checkpoint={teacher_path}", "params.config.full_experiment_name=null",
        f"params.config.score_to_win={0.93 * teacher}", "params.config.max_frames=500000", "params.torch_threads=1"])
    result = runner.train()
    best = glob.glob(str(tmp_path / "runs" / "*" / "nn" / "distill_halfcheetah_lstm.pth"))[0]
    student = played(runner.params, best, games=2)
    assert student >= 0.9 * teacher, (student, teacher, result)


def test_student_of_a_sac_teacher_reaches_pendulum_score(tmp_path):
    """distill_pendulum_sac.yaml: an MLP student fitted (MSE) to the shipped SAC teacher's deterministic actions
    plays Pendulum to score_to_win -250 on its own (measured 60-69 epochs over seeds 5, 1, 2; ~11 s; the
    student then plays -150 over 10 games, its teacher about -143)."""
    teacher_path = resolve_checkpoint("pendulum_sac")[0]
    runner = Runner().load(os.path.join(CONFIGS, "distill_pendulum_sac.yaml"), [
        f"params.config.train_dir={tmp_path}/runs", "params.config.print_stats=false",
        f"params.config.teacher_checkpoint={teacher_path}", "params.config.full_experiment_name=null",
        "params.torch_threads=1"])
    result = runner.train()
    assert result.stop_reason.startswith("score_to_win"), result
    assert result.best_reward >= -250, result
    student = played(runner.params, glob.glob(str(tmp_path / "runs" / "*" / "nn" / "distill_pendulum_sac.pth"))[0],
                     games=10)
    assert student >= -250, (student, result)  # the best student, deterministic, fresh episodes (measured -150)
