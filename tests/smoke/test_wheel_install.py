"""rlchain as a package: the built wheel, installed into a fresh venv outside the clone, trains,
plays a shipped checkpoint, exports to ONNX and runs the push-cube JSON by name, from a folder that is
not the clone.

The fresh venv sees the test venv's packages (torch, gymnasium, envpool, ...) through a ``.pth`` line
holding that venv's site-packages path: a plain path line, so the test venv's own ``.pth`` files (the
editable rlchain's finder among them) are not run there and ``import rlchain`` finds the wheel's copy.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig

import pytest

from tests.conftest import ROOT

pytestmark = pytest.mark.smoke

TIMEOUT = 300


def _env() -> dict[str, str]:
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONUNBUFFERED="1")
    env.pop("PYTHONPATH", None)  # as a user's shell: nothing of the clone on the path
    return env


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    """(venv bin folder, a working folder outside the clone) with the wheel built from this tree installed."""
    if importlib.util.find_spec("setuptools") is None:
        pytest.skip("building the wheel needs setuptools in the test venv")
    base = tmp_path_factory.mktemp("wheel")
    src = base / "src"  # a copy, so the build writes no build/ or egg-info into the clone
    shutil.copytree(os.path.join(ROOT, "rlchain"), src / "rlchain",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for name in ("setup.py", "pyproject.toml"):
        shutil.copy(os.path.join(ROOT, name), src)
    dist = base / "dist"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(dist), str(src)], check=True, capture_output=True, timeout=TIMEOUT)
    (wheel,) = dist.glob("rlchain-*.whl")
    venv = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=TIMEOUT)
    python = venv / "bin" / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             check=True, capture_output=True, text=True).stdout.strip()
    with open(os.path.join(purelib, "test_venv_packages.pth"), "w") as fh:
        fh.write(sysconfig.get_paths()["purelib"] + "\n")
    # pip comes from the test venv (through the .pth); --ignore-installed: leave the editable rlchain be
    subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--ignore-installed",
                    str(wheel)], check=True, capture_output=True, timeout=TIMEOUT, env=_env())
    work = base / "work"
    work.mkdir()
    return venv / "bin", work


def rlchain(fresh, *args: str) -> str:
    """Run the fresh venv's ``rlchain`` console script in the working folder; returns its output."""
    bin_dir, work = fresh
    proc = subprocess.run([str(bin_dir / "rlchain"), *args], cwd=work, env=_env(), capture_output=True, text=True,
                          timeout=TIMEOUT)
    assert proc.returncode == 0, f"rlchain {' '.join(args)}: status {proc.returncode}\n{proc.stdout[-2000:]}\n" \
                                 f"{proc.stderr[-3000:]}"
    return proc.stdout


def test_the_wheel_is_what_runs(fresh):
    bin_dir, work = fresh
    out = subprocess.run([str(bin_dir / "python"), "-c", "import rlchain; print(rlchain.__file__); "
                          "from rlchain.console import main; main(['list'])"], cwd=work, env=_env(),
                         capture_output=True, text=True, timeout=TIMEOUT)
    assert out.returncode == 0, out.stderr
    venv = os.path.realpath(bin_dir.parent)
    assert os.path.realpath(out.stdout.splitlines()[0]).startswith(venv + os.sep), out.stdout[:500]
    assert os.path.realpath(ROOT) not in out.stdout  # the packaged configs are the wheel's too
    assert "push_cube/train_config.json" in out.stdout and "rl_games/halfcheetah_envpool.yaml" in out.stdout


def test_train_play_export_from_outside_the_clone(fresh):
    _, work = fresh
    out = rlchain(fresh, "train", "ppo_cartpole", "params.config.max_epochs=2")
    assert "max_epochs 2 reached" in out
    run = next((work / "runs").iterdir())
    assert (run / "nn" / "last_cartpole.pth").is_file()
    out = rlchain(fresh, "play", "ppo_cartpole", "--checkpoint", "cartpole", "--games", "2")
    assert "av reward: 500.00" in out  # the shipped checkpoint, found by name
    out = rlchain(fresh, "--play", "-c", str(run / "nn" / "last_cartpole.pth"), "--games", "1")  # rl_games' flags
    assert "over 1 games" in out
    if importlib.util.find_spec("onnxruntime") is None or importlib.util.find_spec("onnx") is None:
        pytest.skip("ONNX export needs the onnx extra")
    out = rlchain(fresh, "export", "onnx", "--checkpoint", "cartpole")
    assert (work / "cartpole.onnx").is_file() and "onnxruntime parity" in out


def test_push_cube_json_by_name(fresh):
    pytest.importorskip("envpool")
    out = rlchain(fresh, "train", "push_cube", "params.config.max_epochs=1", "params.config.num_actors=4",
                  "params.config.horizon_length=64", "params.config.minibatch_size=128",
                  "params.config.env_config.max_episode_steps=32")
    assert "epoch 1" in out and "max_epochs 1 reached" in out
