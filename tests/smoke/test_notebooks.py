"""The notebooks in notebooks/ run top to bottom (nbclient, an ipykernel kernel) and are committed stripped.

Each notebook runs in a kernel of its own (forked from a Python that has imported torch, rlchain and ipykernel:
tests/smoke/forked_kernel.py), in its own temporary working directory with RLCHAIN_NOTEBOOK_QUICK=1, which its
``parameters`` cell reads to pick a few epochs instead of the full values. Cells that make a claim
assert it themselves (the ONNX notebook's parity, the custom-network notebook's error message); the
tests add checks on what the cells showed. An executed notebook, stripped by notebooks/strip.py, must
give back the committed file byte for byte.
"""

import json
import os
import signal
import subprocess
import sys
import time

import pytest

from tests.conftest import ROOT

nbformat = pytest.importorskip("nbformat", reason='pip install -e ".[test]"')
nbclient = pytest.importorskip("nbclient", reason='pip install -e ".[test]"')
pytest.importorskip("ipykernel", reason='pip install -e ".[test]"')

pytestmark = pytest.mark.smoke

NOTEBOOKS = os.path.join(ROOT, "notebooks")
STRIP = os.path.join(NOTEBOOKS, "strip.py")
NAMES = ("quickstart", "mujoco_envpool", "onnx_export", "custom_network")
BUDGET_S = 120  # one notebook, kernel start included; quick mode takes ~10-30 s on 2 busy CPU cores
CELL_TIMEOUT_S = 90
KERNEL = "rlchain-test"  # a kernel spec made for this interpreter (fixture kernel_path)
NEEDS = {"mujoco_envpool": ["envpool"], "onnx_export": ["onnx", "onnxruntime"], "quickstart": ["moviepy", "pygame"]}


def _path(name):
    return os.path.join(NOTEBOOKS, f"{name}.ipynb")


def _text(cell):
    """Everything a code cell printed (stdout/stderr and text/plain results)."""
    out = []
    for output in cell.get("outputs", []):
        if output["output_type"] == "stream":
            out.append(output["text"])
        elif "data" in output:
            out.append(output["data"].get("text/plain", ""))
    return "".join(out)


def _mime_types(nb):
    return [key for cell in nb.cells if cell.cell_type == "code" for output in cell.outputs
            for key in output.get("data", {})]


def test_every_notebook_is_listed_and_linked():
    found = sorted(f[:-len(".ipynb")] for f in os.listdir(NOTEBOOKS) if f.endswith(".ipynb"))
    assert found == sorted(NAMES)
    with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
        readme = f.read()
    with open(os.path.join(NOTEBOOKS, "README.md"), encoding="utf-8") as f:
        notebooks_readme = f.read()
    for name in NAMES:
        assert f"(notebooks/{name}.ipynb)" in readme
        assert f"({name}.ipynb)" in notebooks_readme
    # run from a clone: the repository has no known public address, so no Colab (or GitHub) links
    for text in (readme, notebooks_readme, *(open(_path(name), encoding="utf-8").read() for name in NAMES)):
        assert "colab.research.google.com" not in text and "git+https://" not in text
    assert "jupyter notebook notebooks/" in readme and "jupyter notebook notebooks/" in notebooks_readme
    assert "strip.py" in notebooks_readme


@pytest.mark.parametrize("name", NAMES)
def test_committed_notebook_is_stripped(name):
    with open(_path(name), encoding="utf-8") as f:
        nb = json.load(f)
    for i, cell in enumerate(nb["cells"]):
        if cell["cell_type"] == "code":
            assert cell["outputs"] == [], f"{name} cell {i} has outputs: run python notebooks/strip.py"
            assert cell["execution_count"] is None, f"{name} cell {i} has an execution count"
    # the parameter cell: tagged for papermill-style tools, and the test's switch to the quick values
    tagged = [c for c in nb["cells"] if "parameters" in c.get("metadata", {}).get("tags", [])]
    assert len(tagged) == 1 and "RLCHAIN_NOTEBOOK_QUICK" in "".join(tagged[0]["source"])
    nbformat.validate(nbformat.reads(json.dumps(nb), as_version=4))
    # strip.py agrees that the file is stripped (it also normalizes the layout)
    check = subprocess.run([sys.executable, STRIP, "--check", _path(name)], capture_output=True, text=True)
    assert check.returncode == 0, check.stdout + check.stderr


@pytest.fixture(scope="module")
def kernel_path(tmp_path_factory):
    """A JUPYTER_PATH with a kernel spec for this interpreter: a machine-wide ``python3`` spec pointing
    at another Python (without rlchain) must not be the one the notebooks run on."""
    root = tmp_path_factory.mktemp("jupyter")
    spec = root / "kernels" / KERNEL
    spec.mkdir(parents=True)
    argv = [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"]
    (spec / "kernel.json").write_text(json.dumps({"argv": argv, "display_name": KERNEL, "language": "python"}))
    return str(root)


@pytest.fixture(scope="module")
def kernel_server(kernel_path):
    """The fork server the kernels start in (tests/smoke/forked_kernel.py), or None where RLCHAIN_TESTS_FRESH=1
    asks for fresh kernels."""
    if os.environ.get("RLCHAIN_TESTS_FRESH") == "1":
        yield None
        return
    from tests.smoke.forked_kernel import preloaded_server

    with preloaded_server(dict(os.environ, **kernel_environment(kernel_path))) as server:
        yield server


def kernel_environment(kernel_path) -> dict[str, str]:
    """What the test sets in the kernels' environment."""
    return {"RLCHAIN_NOTEBOOK_QUICK": "1",
            "MPLBACKEND": "module://matplotlib_inline.backend_inline",  # figures as image/png
            "JUPYTER_PATH": kernel_path}


@pytest.fixture(scope="module")
def timings():
    found: dict = {}
    yield found
    if found:
        print("\nnotebook times: " + ", ".join(f"{k} {v:.1f} s" for k, v in found.items()))


@pytest.mark.timeout(BUDGET_S + 60)
@pytest.mark.parametrize("name", NAMES)
def test_notebook_runs_top_to_bottom(name, tmp_path, monkeypatch, kernel_path, kernel_server, timings):
    for module in NEEDS.get(name, []):
        pytest.importorskip(module)
    for key, value in kernel_environment(kernel_path).items():
        monkeypatch.setenv(key, value)
    if kernel_server is not None:
        from jupyter_client.provisioning import local_provisioner

        from tests.smoke.forked_kernel import forked_launcher

        monkeypatch.setattr(local_provisioner, "launch_kernel", forked_launcher(kernel_server))
    nb = nbformat.read(_path(name), as_version=4)
    client = nbclient.NotebookClient(nb, timeout=CELL_TIMEOUT_S, kernel_name=KERNEL,
                                     resources={"metadata": {"path": str(tmp_path)}})
    start = time.monotonic()
    sigint = signal.getsignal(signal.SIGINT)
    try:
        client.execute()  # a cell that raises fails here with CellExecutionError naming the cell
    finally:
        # the Jupyter client sets Python's own SIGINT handler in this process; a suite started with
        # SIGINT ignored (nohup, a background CI job) would otherwise keep it (conftest checks)
        signal.signal(signal.SIGINT, sigint)
    elapsed = time.monotonic() - start
    timings[name] = elapsed
    assert elapsed < BUDGET_S, f"{name} took {elapsed:.0f} s in quick mode"
    text = "\n".join(_text(c) for c in nb.cells if c.cell_type == "code")
    assert "Traceback" not in text

    if name == "quickstart":
        assert "epoch 1/4" in text and "epoch 4/4" in text  # the console progress, quick values in force
        assert "image/png" in _mime_types(nb)  # the reward curve
        assert any("<video" in d for c in nb.cells for o in c.get("outputs", [])
                   for d in [o.get("data", {}).get("text/html", "")])
        assert "av reward" in text and "epochs 4 -> 6" in text
        assert "did you mean 'learning_rate'?" in text
        assert list(tmp_path.glob("runs/*/videos/*.mp4"))
    elif name == "mujoco_envpool":
        assert "HalfCheetah-v4" in text and "epoch 8/8" in text
        assert "image/png" in _mime_types(nb)
        assert "deterministic policy: mean reward" in text and "stochastic policy: mean reward" in text
    elif name == "onnx_export":
        for policy in ("cartpole", "pendulum", "lstm"):
            assert f"{policy}: 100 steps" in text and (tmp_path / f"{policy}.onnx").is_file()
        assert text.count("onnxruntime parity") == 3
        assert "rnn_state_0" in text and "rnn_state_1_out" in text
    elif name == "custom_network":
        assert "ResidualMlpConfig(name='residual_mlp', hidden=32, blocks=2)" in text
        assert "params.network.hiden: unknown key; did you mean 'hidden'?" in text

    # stripping the executed notebook gives back the committed file
    executed = tmp_path / f"{name}.ipynb"
    nbformat.write(nb, str(executed))
    subprocess.run([sys.executable, STRIP, str(executed)], check=True, capture_output=True)
    with open(_path(name), encoding="utf-8") as f:
        assert executed.read_text(encoding="utf-8") == f.read()
