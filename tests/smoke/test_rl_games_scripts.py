"""Scripts written against rl_games run on rlchain: the launcher (``python -m rlchain.rl_games SCRIPT``),
the Isaac-Lab-style train.py / play.py of examples/isaac_style (train, resume, play), and an AlgoObserver
written for rl_games running unchanged."""

import glob
import os
import subprocess
import sys

import pytest
import yaml

from rlchain.rl_games import alias
from tests.conftest import ROOT
from tests.smoke.cli_server import run_python

pytestmark = pytest.mark.smoke

EXAMPLE = os.path.join(ROOT, "examples", "isaac_style")
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONWARNINGS": "ignore", "PYTHONPATH": ROOT}  # this checkout's rlchain


def launch(args, cwd, env=None, timeout=300, fresh=False):
    """``python -m rlchain.rl_games ARGS`` in ``cwd``: in a child of the fork server (it has imported torch and
    rlchain: tests/smoke/cli_server.py), or with ``fresh`` in a new process, whose ``sys.path`` follows ``env``'s
    PYTHONPATH (a fork server's child keeps the server's)."""
    argv = [sys.executable, "-m", "rlchain.rl_games", *args]
    if fresh:
        return subprocess.run(argv, cwd=cwd, env=env or ENV, capture_output=True, text=True, timeout=timeout)
    return run_python(argv, cwd, env or ENV, timeout)


SCRIPT = """
import sys
import rl_games
from rl_games.torch_runner import Runner
from rl_games.common import env_configurations, vecenv
from rl_games.common.algo_observer import AlgoObserver, DefaultAlgoObserver, IsaacAlgoObserver
from rl_games.common.player import BasePlayer
from rl_games.algos_torch import model_builder, network_builder, torch_ext
import rlchain.rl_games.torch_runner
assert Runner is rlchain.rl_games.torch_runner.Runner
assert vecenv.IVecEnv.__module__ == "rlchain.rl_games.common.ivecenv"
print("ARGV", sys.argv)
print("NAME", __name__)
print("PATH0", sys.path[0])
print("RL_GAMES", rl_games.__name__, hasattr(rl_games, "REAL"))
sys.exit(int(sys.argv[-1]))
"""


def test_launcher_runs_a_script_as_python_would(tmp_path):
    # a stand-in "real" rl_games on the path: the launched script must not see it, plain python must
    fake = tmp_path / "site" / "rl_games"
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text("REAL = True\n")
    env = {**ENV, "PYTHONPATH": os.pathsep.join([str(tmp_path / "site"), ROOT])}
    script = tmp_path / "scripts" / "train.py"
    script.parent.mkdir()
    script.write_text(SCRIPT)
    out = launch([str(script), "--task", "x", "3"], tmp_path, env, fresh=True)
    assert out.returncode == 3, out.stderr
    lines = out.stdout.splitlines()
    assert lines[0].startswith("rlchain ") and "stands in for rl_games" in lines[0]
    assert f"ARGV {[str(script), '--task', 'x', '3']}" in lines
    assert "NAME __main__" in lines and f"PATH0 {script.parent}" in lines
    assert "RL_GAMES rlchain.rl_games False" in lines  # one module object under both names
    plain = subprocess.run([sys.executable, "-c", "import rl_games; print(rl_games.REAL)"], cwd=tmp_path, env=env,
                           capture_output=True, text=True)
    assert plain.stdout.strip() == "True", plain.stderr  # other processes: the real one, untouched


def _run_folder(log_root):
    runs = sorted(glob.glob(os.path.join(log_root, "cartpole_direct", "*", "")))
    assert runs, f"no run folder under {log_root}"
    return runs[-1]


def _last(run):
    """The checkpoint rl_games (and rlchain through its API) writes when a run stops:
    nn/last_<name>_ep_<N>_rew__<R>_.pth."""
    found = sorted(glob.glob(os.path.join(run, "nn", "last_cartpole_direct_ep_*_rew_*_.pth")), key=os.path.getmtime)
    assert found, f"no final checkpoint in {run}/nn: {os.listdir(os.path.join(run, 'nn'))}"
    return found[-1]


def _tags(run):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(os.path.join(run, "summaries"))
    events.Reload()
    return set(events.Tags()["scalars"])


def test_isaac_style_scripts_train_resume_and_play(tmp_path):
    logs = str(tmp_path / "logs")
    train = os.path.join(EXAMPLE, "train.py")
    out = launch([train, "--num_envs", "128", "--max_iterations", "2", "--log_root", logs], tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "stands in for rl_games" in out.stdout.splitlines()[0]
    assert "max_epochs 2 reached at epoch 2" in out.stdout
    first = _run_folder(logs)
    tags = _tags(first)
    assert {"Episode/Episode_Reward/alive", "Episode/Episode_Termination/pole_fell", "rewards/step"} <= tags
    last = _last(first)
    assert os.path.basename(last).startswith("last_cartpole_direct_ep_2_rew__")
    import torch

    raw = torch.load(last, weights_only=False)  # rl_games' keys beside rlchain's: its own code reads them
    assert {"model", "optimizer", "epoch", "frame", "last_mean_rewards", "rlchain_model", "format"} <= set(raw)
    assert any(k.startswith("a2c_network.") for k in raw["model"]) and raw["epoch"] == 2 and raw["frame"] > 0
    out = launch([train, "--num_envs", "128", "--max_iterations", "3", "--log_root", logs, "--checkpoint", last],
                 tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "at epoch 2" in out.stdout and "max_epochs 3 reached at epoch 3" in out.stdout
    out = launch([os.path.join(EXAMPLE, "play.py"), "--checkpoint", last, "--steps", "120", "--num_envs", "8"],
                 tmp_path)
    assert out.returncode == 0, out.stderr[-3000:]
    assert "played 120 steps" in out.stdout and "0 episodes ended" not in out.stdout


@pytest.fixture
def isaac_env(monkeypatch, scoped_registries):
    """examples/isaac_style/cartpole_env.py imported in this process (it imports rl_games' names)."""
    monkeypatch.syspath_prepend(EXAMPLE)
    alias.install()
    try:
        import cartpole_env

        yield cartpole_env
    finally:
        alias.uninstall()
        sys.modules.pop("cartpole_env", None)


def curriculum_env_class(isaac_env):
    class CurriculumEnv(isaac_env.RlGamesGpuEnv):  # rl_games' curriculum hooks of an IVecEnv
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.frames_seen, self.level, self.restored = [], 0, None

        def set_train_info(self, env_frames, *args, **kwargs):
            self.frames_seen.append(env_frames)
            self.level = env_frames // 4096

        def get_env_state(self):
            return {"level": self.level}

        def set_env_state(self, env_state):
            self.restored = env_state

    return CurriculumEnv


def test_an_rl_games_observer_runs_unchanged(tmp_path, isaac_env):
    """... and an IVecEnv's set_train_info / get_env_state / set_env_state are called as rl_games calls them."""
    from rl_games.algos_torch import torch_ext
    from rl_games.common import env_configurations, vecenv
    from rl_games.common.algo_observer import AlgoObserver
    from rl_games.torch_runner import Runner

    class AliveObserver(AlgoObserver):  # as one writes it for rl_games
        def __init__(self):
            super().__init__()
            self.calls = []

        def before_init(self, base_name, config, experiment_name):
            self.calls.append(("before_init", base_name))

        def after_init(self, algo):
            self.algo = algo
            self.writer = algo.writer
            self.alive = torch_ext.AverageMeter(1, self.algo.games_to_track).to(self.algo.ppo_device)
            self.calls.append(("after_init", algo.games_to_track))

        def process_infos(self, infos, done_indices):
            if "episode" in infos:
                self.alive.update(infos["episode"]["Episode_Reward/alive"].reshape(1, 1))

        def after_steps(self):
            self.calls.append(("after_steps", self.algo.epoch_num))  # the epoch running, as rl_games counts

        def after_print_stats(self, frame, epoch_num, total_time):
            self.calls.append(("print", frame, epoch_num, self.algo.frame, self.algo.epoch_num))
            self.writer.add_scalar("alive/mean", self.alive.get_mean(), frame)

    env = isaac_env.RlGamesVecEnvWrapper(isaac_env.CartpoleDirectEnv(128, "cpu", seed=3), "cpu", 5.0, 1.0)
    curriculum, made = curriculum_env_class(isaac_env), []
    vecenv.register("IsaacRlgWrapper", lambda name, n, **kw: made.append(curriculum(name, n, **kw)) or made[-1])
    env_configurations.register("rlgpu", {"vecenv_type": "IsaacRlgWrapper", "env_creator": lambda **kwargs: env})
    with open(os.path.join(EXAMPLE, "agents", "rl_games_ppo_cfg.yaml")) as fh:
        cfg = yaml.safe_load(fh)
    cfg["params"]["config"].update(num_actors=128, max_epochs=2, train_dir=str(tmp_path / "runs"),
                                   games_to_track=50)
    observer = AliveObserver()
    runner = Runner(observer)
    runner.load(cfg)
    runner.reset()
    result = runner.run({"train": True, "play": False, "sigma": None})
    assert result.epoch == 2
    batch = 128 * 32
    assert observer.calls[:2] == [("before_init", "cartpole_direct"), ("after_init", 50)]
    prints = [c for c in observer.calls if c[0] == "print"]
    # rl_games: the frames before the epoch as the argument, algo.frame after it
    assert prints == [("print", 0, 1, batch, 1), ("print", batch, 2, 2 * batch, 2)]
    assert [c for c in observer.calls if c[0] == "after_steps"][:2] == [("after_steps", 1), ("after_steps", 2)]
    assert observer.alive.current_size > 0
    assert "alive/mean" in _tags(result.run_dir)
    assert made[0].frames_seen[:3] == [0, batch, 2 * batch]  # before every epoch, as rl_games calls it
    cfg["params"]["config"]["max_epochs"] = 3
    runner.load(cfg)
    runner.run({"train": True, "checkpoint": _last(result.run_dir)})
    assert made[1].restored == {"level": 2}  # the checkpoint carried the env's state
    cfg["params"]["config"]["player"] = {"use_vecenv": True, "num_actors": 128, "games_num": 4}
    runner.load(cfg)
    played = runner.run({"train": False, "play": True, "checkpoint": _last(result.run_dir)})
    assert played.games == 4 and played.mean_reward > 0


def test_stop_fn_in_the_config_dict_stops_the_run(tmp_path, base_config):
    from rlchain.rl_games.torch_runner import Runner

    seen = []

    def stop_fn(algo):  # rl_games 2.0: callable(algo) -> bool after every epoch
        seen.append(algo.epoch_num)
        return algo.epoch_num >= 3

    base_config["params"]["config"].update(max_epochs=50, train_dir=str(tmp_path), print_stats=False,
                                           stop_fn=stop_fn)
    runner = Runner()
    runner.load(base_config)
    result = runner.run({"train": True, "play": False})
    assert result.epoch == 3 and seen == [1, 2, 3] and "stop_fn" in result.stop_reason



def test_the_observers_algo_has_what_rl_games_and_isaac_lab_observers_read(tmp_path, base_config):
    import torch

    from rlchain.rl_games.common.algo_observer import AlgoObserver
    from rlchain.rl_games.torch_runner import Runner

    class Reader(AlgoObserver):
        def after_init(self, algo):
            self.algo = algo
            self.seen = {"train_dir": algo.train_dir, "experiment_dir": algo.experiment_dir,
                         "optimizer": type(algo.optimizer).__name__, "last_lr": algo.last_lr}

        def after_print_stats(self, frame, epoch_num, total_time):
            if epoch_num == 1:
                self.weights = self.algo.get_full_state_weights()
            else:  # what population-based training does: load another member's weights into the running run
                self.algo.set_full_state_weights(self.weights, set_epoch=False)
                self.after = self.algo.get_full_state_weights()

    base_config["params"]["config"].update(train_dir=str(tmp_path), max_epochs=2, learning_rate=1e-3)
    observer = Reader()
    runner = Runner(observer)
    runner.load(base_config)
    runner.run({"train": True})
    assert observer.seen["train_dir"] == str(tmp_path) and observer.seen["experiment_dir"].startswith(str(tmp_path))
    assert observer.seen["optimizer"] == "Adam" and observer.seen["last_lr"] == pytest.approx(1e-3)
    assert all(torch.equal(observer.after["model"][k], v) for k, v in observer.weights["model"].items())
    assert observer.after["epoch"] == 2  # set_epoch=False keeps the run's counters


def test_an_rl_games_checkpoint_resumes_under_the_launcher(tmp_path, monkeypatch, scoped_registries):
    """tests/data/rl_games/make_checkpoints.py's own training code, run with rlchain standing in for rl_games,
    fine-tunes the checkpoint real rl_games 1.6.5 wrote with it."""
    import copy

    pytest.importorskip("gym")
    data = os.path.join(ROOT, "tests", "data", "rl_games")
    monkeypatch.syspath_prepend(data)
    alias.install()
    try:
        import make_checkpoints
        from rl_games.common import env_configurations, vecenv
        from rl_games.torch_runner import Runner

        env_class = make_checkpoints.make_env_class("continuous")
        vecenv.register("TINY", lambda config_name, num_actors, **kwargs: env_class(num_actors))
        env_configurations.register("tiny_env", {"vecenv_type": "TINY", "env_creator": lambda **kwargs: env_class(4)})
        cfg = copy.deepcopy(make_checkpoints.CONFIGS["continuous"])
        cfg["params"]["config"].update(train_dir=str(tmp_path), max_epochs=3)
        runner = Runner()
        runner.load(cfg)
        result = runner.run({"train": True, "checkpoint": os.path.join(data, "v165_continuous.pth")})
    finally:
        alias.uninstall()
        sys.modules.pop("make_checkpoints", None)
    assert (result.epoch, result.frames) == (3, 64 + 32)  # rl_games' counters carried on
