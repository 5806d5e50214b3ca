"""rlchain as a package: the built wheel, installed into a fresh venv outside the clone, trains,
plays a shipped checkpoint, exports to ONNX and runs the push-cube JSON by name, from a folder that is
not the clone.

The fresh venv sees the test venv's packages (torch, gymnasium, envpool, ...) through a ``.pth`` line
holding that venv's site-packages path: a plain path line, so the test venv's own ``.pth`` files (the
editable rlchain's finder among them) are not run there and ``import rlchain`` finds the wheel's copy.

The installed ``rlchain`` console script runs once as a fresh process (``rlchain list``); the other commands run
what that script runs (the wheel's ``rlchain.console.main``, with the same argv) in children of a fork server on
the fresh venv's Python (tests/smoke/forkserver.py ``--installed``), which has imported the wheel's rlchain and torch
once: each command pays for its own work, not about 4 s of CPU to import them again.
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
from tests.smoke.forkserver_client import ForkServer

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


@pytest.fixture(scope="module")
def server(fresh):
    """The fork server on the fresh venv's Python, with the wheel's rlchain imported."""
    bin_dir, work = fresh
    forks = ForkServer(_env(), python=str(bin_dir / "python"), installed=True, cwd=str(work))
    yield forks
    forks.close()


def run(fresh, server, argv: list[str]) -> str:
    """``argv`` (the fresh venv's ``rlchain`` or ``python``) in the working folder, in a child of ``server``;
    asserts it exits 0 and returns its output."""
    _, work = fresh
    status, stdout, stderr = server.run(argv, str(work), _env(), TIMEOUT)
    assert status == 0, f"{' '.join(argv)}: status {status}\n{stdout[-2000:]}\n{stderr[-3000:]}"
    return stdout


def rlchain(fresh, server, *args: str) -> str:
    """``rlchain ARGS`` of the fresh venv (its console script's main) in the working folder; returns its output."""
    return run(fresh, server, [str(fresh[0] / "rlchain"), *args])


def test_the_wheel_is_what_runs(fresh, server):
    bin_dir, work = fresh
    venv = os.path.realpath(bin_dir.parent)
    # the installed console script, as a fresh process
    out = subprocess.run([str(bin_dir / "rlchain"), "list"], cwd=work, env=_env(), capture_output=True, text=True,
                         timeout=TIMEOUT)
    assert out.returncode == 0, out.stderr
    assert os.path.realpath(ROOT) not in out.stdout  # the packaged configs are the wheel's
    assert "push_cube/train_config.json" in out.stdout and "rl_games/halfcheetah_envpool.yaml" in out.stdout
    configs = out.stdout.splitlines()[0].split(", in ", 1)[-1].rstrip(":")  # "configs (...), in DIR:"
    assert os.path.realpath(configs).startswith(venv + os.sep), out.stdout[:500]
    # the fork server's commands (the tests below) run the wheel's rlchain, not the clone's
    out = run(fresh, server, [str(bin_dir / "python"), "-c", "import rlchain, rlchain.console; "
                              "print(rlchain.__file__); print(rlchain.console.__file__)"])
    assert all(os.path.realpath(path).startswith(venv + os.sep) for path in out.splitlines()), out


def test_train_play_export_from_outside_the_clone(fresh, server):
    _, work = fresh
    out = rlchain(fresh, server, "train", "ppo_cartpole", "params.config.max_epochs=2")
    assert "max_epochs 2 reached" in out
    run = next((work / "runs").iterdir())
    assert (run / "nn" / "last_cartpole.pth").is_file()
    out = rlchain(fresh, server, "play", "ppo_cartpole", "--checkpoint", "cartpole", "--games", "2")
    assert "av reward: 500.00" in out  # the shipped checkpoint, found by name
    # rl_games' flags
    out = rlchain(fresh, server, "--play", "-c", str(run / "nn" / "last_cartpole.pth"), "--games", "1")
    assert "over 1 games" in out
    if importlib.util.find_spec("onnxruntime") is None or importlib.util.find_spec("onnx") is None:
        pytest.skip("ONNX export needs the onnx extra")
    out = rlchain(fresh, server, "export", "onnx", "--checkpoint", "cartpole")
    assert (work / "cartpole.onnx").is_file() and "onnxruntime parity" in out


def test_push_cube_json_by_name(fresh, server):
    pytest.importorskip("envpool")
    out = rlchain(fresh, server, "train", "push_cube", "params.config.max_epochs=1", "params.config.num_actors=4",
                  "params.config.horizon_length=64", "params.config.minibatch_size=128",
                  "params.config.env_config.max_episode_steps=32")
    assert "epoch 1" in out and "max_epochs 1 reached" in out
