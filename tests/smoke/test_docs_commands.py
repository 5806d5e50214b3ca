"""Every command the docs show runs: README.md and docs/*.md, block by block.

Each ``bash`` / ``python`` fenced block carries a marker, an HTML comment on the line before it
(docs/layout.md, "The docs are tested", has the table)::

    <!-- test: run -->                 run it (bash: line by line; python: as a script)
    <!-- test: run status=2 -->        every command must exit with this status (error examples)
    <!-- test: run timeout=10 -->      runs until stopped (a server): must still run after 10 s
    <!-- test: output -->              (a plain block) its lines must appear in the last run's output
    <!-- test: file mypkg/x.py -->     write the block there, for the blocks after it
    <!-- test: skip REASON -->         not run (hours of training, a cluster, a fresh install)

A page runs in a fresh working directory (runner.py, train.py and nn/ copied; rlchain/,
benchmarks/, tests/ linked), its blocks in page order. Commands are shortened the same way
everywhere: training gets ``params.config.max_epochs=1`` appended (after the page's own
overrides, so it wins), ``--play`` gets ``params.config.player.games_num=2`` (a ``--games N``
flag still wins), ``--tune SEARCH`` runs a copy of the search with 2 trials of 2 epochs, a
``.learn(N)`` in a bash command (``python -c "...learn(50_000)..."``) learns ``SHORT_LEARN`` steps, and
``<run>`` is the newest run folder under ``runs/``. A python block says the same in Python: its
``Runner().load(...)`` trains at most 2 epochs and an SB3-style ``.learn(N)`` at most ``SHORT_LEARN`` steps
(tests/smoke/docs_caps.py). ``rlchain ...`` commands get the same
shortening (``rlchain train``/``play``/``tune`` as ``--train``/``--play``/``--tune``, also after
``python -m`` / ``torchrun -m``); a leading ``rlchain`` runs the console script of the venv the
tests run in (``python -m rlchain`` where that venv has none).
A bash command that an earlier page already ran successfully in this session is not run again on
a page where no later block can depend on it (no python or file blocks, no ``<run>``).
A ``run timeout=N`` command runs in the background (tests/smoke/docs_background.py) while the page's later blocks
and the pages after it run; the last test checks that each was still running ``N`` seconds after its start.
"""

from __future__ import annotations

import glob
import os
import re
import resource
import shlex
import shutil
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field

import pytest
import yaml

from rlchain.config.packaged import resolve_config
from tests.conftest import ROOT
from tests.smoke import docs_background
from tests.smoke.forkserver_client import ForkServer

pytestmark = pytest.mark.smoke

DOCS = os.path.join(ROOT, "docs")
GENERATED = {"docs/config.md"}  # python -m rlchain.config.docs writes it; it shows no commands
PAGES = ["README.md"] + sorted(f"docs/{name}" for name in os.listdir(DOCS)
                               if name.endswith(".md") and f"docs/{name}" not in GENERATED)
COMMAND_LANGS = {"bash", "sh", "shell", "console", "python", "py"}
KINDS = {"run", "skip", "file", "output"}
MARKER = re.compile(r"^<!--\s*test:\s*(\w+)\s*(.*?)\s*-->$")
FENCE = re.compile(r"^(```+|~~~+)\s*([\w+-]*)")
COMMAND_TIMEOUT = 300  # seconds for one command; the page's test has pytest's own limit
STOP_GRACE = 5  # seconds a stopped server or watcher has to exit after SIGINT before it is killed
SHORT_LEARN = 2048  # steps of an SB3-style ``.learn(N)`` in a bash command
LEARN_CALL = re.compile(r"\.learn\(\s*(?:total_timesteps\s*=\s*)?[\d_]+")
COPIED = ("runner.py", "train.py", "nn")  # a command may write next to them: copies, not links
LINKED = ("rlchain", "benchmarks", "tests", "notebooks", "examples")
CAPS = os.path.join(ROOT, "tests", "smoke", "docs_caps.py")  # a python block's training, capped like a command's
CAPS_PRELUDE = "tests.smoke.docs_caps:install"

_ran_ok: set[str] = set()  # bash commands (shortened) that succeeded on an earlier page
_background: list[docs_background.Background] = []  # `run timeout=N` commands running on (docs_background.py)


@dataclass
class Block:
    page: str
    line: int  # of the opening fence, 1-based
    lang: str
    text: str
    kind: str | None  # the marker's kind; None: no marker
    args: str = ""
    options: dict = field(default_factory=dict)

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"


def read_blocks(page: str) -> list[Block]:
    """The page's fenced blocks with the marker on the line before each (if any)."""
    with open(os.path.join(ROOT, page), encoding="utf-8") as fh:
        lines = fh.read().splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, lang = m.group(1), m.group(2).lower()
        end = i + 1
        while end < len(lines) and lines[end].strip() != fence:
            end += 1
        marker = MARKER.match(lines[i - 1].strip()) if i > 0 else None
        kind, args = (marker.group(1), marker.group(2)) if marker else (None, "")
        options = {}
        if kind == "run":
            options = dict(item.partition("=")[::2] for item in shlex.split(args))
        blocks.append(Block(page, i + 1, lang, "\n".join(lines[i + 1:end]), kind, args, options))
        i = end + 1
    return blocks


def marker_problems(blocks: list[Block]) -> list[str]:
    problems = []
    previous_run = False
    for block in blocks:
        if block.kind is not None and block.kind not in KINDS:
            problems.append(f"{block.where}: unknown marker 'test: {block.kind}' (one of {sorted(KINDS)})")
        elif block.lang in COMMAND_LANGS and block.kind not in ("run", "skip", "file"):
            problems.append(f"{block.where}: a {block.lang} block needs <!-- test: run -->, <!-- test: file PATH --> "
                            f"or <!-- test: skip REASON --> on the line before it")
        elif block.kind == "skip" and not block.args:
            problems.append(f"{block.where}: 'test: skip' needs a reason")
        elif block.kind == "file" and not block.args:
            problems.append(f"{block.where}: 'test: file' needs a path")
        elif block.kind == "run" and set(block.options) - {"status", "timeout"}:
            problems.append(f"{block.where}: unknown run options {sorted(set(block.options) - {'status', 'timeout'})}")
        elif block.kind == "run" and block.lang not in COMMAND_LANGS:
            problems.append(f"{block.where}: 'test: run' on a '{block.lang}' block (bash or python only)")
        elif block.kind == "output" and not previous_run:
            problems.append(f"{block.where}: 'test: output' must follow a 'test: run' block")
        if block.kind in ("run", "output"):
            previous_run = block.kind == "run" or previous_run
        elif block.lang in COMMAND_LANGS or block.kind is not None:
            previous_run = False
    return problems


def test_every_command_block_is_marked():
    problems = [p for page in PAGES for p in marker_problems(read_blocks(page))]
    assert not problems, "\n".join(problems)


def test_the_marker_check_sees_an_unmarked_block():
    blocks = [Block("x.md", 1, "bash", "ls", None), Block("x.md", 5, "python", "1", "skip"),
              Block("x.md", 9, "text", "out", "output")]
    problems = marker_problems(blocks)
    assert len(problems) == 3 and "x.md:1" in problems[0] and "reason" in problems[1] and "follow" in problems[2]


def test_rlchain_commands_are_shortened_like_runner_py(tmp_path):
    launcher = shlex.join(rlchain_command())
    assert shorten("rlchain train ppo_cartpole lr=1", str(tmp_path)) == \
        f"{launcher} train ppo_cartpole lr=1 params.config.max_epochs=1"
    assert shorten("rlchain play --checkpoint cartpole  # shipped", str(tmp_path)) == \
        f"{launcher} play --checkpoint cartpole params.config.player.games_num=2"
    assert shorten("rlchain -t -f x.yaml", str(tmp_path)) == f"{launcher} -t -f x.yaml params.config.max_epochs=1"
    assert shorten("rlchain export onnx -c cartpole", str(tmp_path)) == f"{launcher} export onnx -c cartpole"
    assert shorten("torchrun --nproc_per_node=2 -m rlchain train ppo_cartpole", str(tmp_path)) == \
        "torchrun --nproc_per_node=2 -m rlchain train ppo_cartpole params.config.max_epochs=1"
    learn = "python -c \"import rlchain; rlchain.PPO('MlpPolicy', 'CartPole-v1').learn(50_000).save('x')\""
    assert f".learn({SHORT_LEARN}).save" in shorten(learn, str(tmp_path))
    tuned = shlex.split(shorten("rlchain tune tune_cartpole", str(tmp_path)))
    with open(tuned[-1], encoding="utf-8") as fh:
        assert yaml.safe_load(fh)["trials"] == 2


def test_plain_commands_go_to_the_fork_server(tmp_path):
    code = "python -c \"import rlchain; rlchain.PPO('MlpPolicy', 'CartPole-v1').learn(50_000).save('x')\""
    assert forkable(code, shorten(code, str(tmp_path)))[:2] == ["python", "-c"]
    assert split_assignments(forkable("WANDB_MODE=offline python runner.py --train", "WANDB_MODE=offline python "
                                      "runner.py --train")) == ({"WANDB_MODE": "offline"}, ["python", "runner.py",
                                                                                            "--train"])
    torchrun = "torchrun --standalone --nnodes=1 --nproc_per_node=2 -m rlchain train ppo_cartpole"
    assert forkable(torchrun, shorten(torchrun, str(tmp_path)))[0] == "torchrun"  # its workers: forks too
    resume = "rlchain train ppo_cartpole --checkpoint runs/<run>/nn/last_cartpole.pth  # resume"
    assert forkable(resume, "rlchain train ppo_cartpole --checkpoint runs/r/nn/last_cartpole.pth")[-1].endswith("pth")
    writers = "python runner.py params.import_modules=[mywriters] params.config.log_writers=[wide_csv,csv]"
    assert forkable(writers, writers, str(tmp_path))[-1] == "params.config.log_writers=[wide_csv,csv]"
    assert forkable(writers, writers) is None  # no folder to check the globs against
    (tmp_path / "x.py").write_text("")
    assert forkable("python *.py", "python *.py", str(tmp_path)) is None  # it matches: bash expands it
    for shell in ("python x.py > out.txt", "python -c 'print(1)' | cat", "X=$HOME python x.py", "ls runs/*",
                  "tensorboard --logdir runs", "FOO=1 ls", 'python -c "print($X)"', "cd x && python y.py"):
        assert forkable(shell, shell) is None, shell


# ----- running a page -------------------------------------------------------------------------
def commands(text: str) -> list[str]:
    """Logical command lines of a bash block: continuations joined, blank and comment lines dropped."""
    joined = re.sub(r"\\\n\s*", " ", text)
    return [line for line in joined.splitlines() if line.strip() and not line.strip().startswith("#")]


def newest_run(ws: str) -> str:
    runs = os.path.join(ws, "runs")
    found = [d for d in os.listdir(runs) if os.path.isdir(os.path.join(runs, d))] if os.path.isdir(runs) else []
    if not found:
        raise AssertionError("<run> in a command, but no run folder under runs/ yet")
    return max(found, key=lambda d: os.path.getmtime(os.path.join(runs, d)))


def short_search(path: str, ws: str) -> str:
    """A copy of the search file with 2 trials of 2 epochs, its base made absolute."""
    source = os.path.join(ws, path)
    with open(source, encoding="utf-8") as fh:
        spec = yaml.safe_load(fh)
    spec["base"] = os.path.normpath(os.path.join(os.path.dirname(os.path.realpath(source)), spec["base"]))
    spec.update(trials=2, max_epochs_per_trial=2)
    out = os.path.join(ws, "_short_" + os.path.basename(path))
    with open(out, "w", encoding="utf-8") as fh:
        yaml.safe_dump(spec, fh)
    return out


def rlchain_command() -> list[str]:
    """The ``rlchain`` console script of the venv the tests run in; ``python -m rlchain`` (the same main) where
    that venv was installed before the script existed."""
    script = os.path.join(os.path.dirname(sys.executable), "rlchain")
    return [script] if os.path.isfile(script) else [sys.executable, "-m", "rlchain"]


def shorten(command: str, ws: str) -> str:
    """The command as the test runs it (see the module docstring)."""
    tokens = shlex.split(command, comments=True)
    at = next((i for i, t in enumerate(tokens) if t == "rlchain" and (i == 0 or tokens[i - 1] == "-m")), None)
    if at is not None:  # the console script or `-m rlchain` (python, torchrun): subcommands are runner.py's flags
        subcommand = tokens[at + 1] if len(tokens) > at + 1 else ""
        if subcommand == "tune" and len(tokens) > at + 2:
            tokens[at + 2] = short_search(resolve_config(tokens[at + 2]), ws)
        elif subcommand == "train" or "--train" in tokens or "-t" in tokens:
            tokens.append("params.config.max_epochs=1")
        elif subcommand == "play" or "--play" in tokens or "-p" in tokens:
            tokens.append("params.config.player.games_num=2")
        if at == 0:
            tokens = rlchain_command() + tokens[1:]
    elif any(t.endswith(("runner.py", "train.py")) for t in tokens):
        if "--tune" in tokens:
            i = tokens.index("--tune") + 1
            tokens[i] = short_search(tokens[i], ws)
        elif "--train" in tokens or "-t" in tokens or any(t.endswith("train.py") for t in tokens):
            tokens.append("params.config.max_epochs=1")
        elif "--play" in tokens or "-p" in tokens:
            tokens.append("params.config.player.games_num=2")
    tokens = [LEARN_CALL.sub(f".learn({SHORT_LEARN}", t) for t in tokens]
    if any("<run>" in t for t in tokens):
        run = newest_run(ws)
        tokens = [t.replace("<run>", run) for t in tokens]
    return shlex.join(tokens)


def workspace(path: str) -> str:
    os.makedirs(path, exist_ok=True)
    for name in COPIED:
        src = os.path.join(ROOT, name)
        if os.path.isdir(src):
            shutil.copytree(src, os.path.join(path, name))
        else:
            shutil.copy(src, path)
    for name in LINKED:
        os.symlink(os.path.join(ROOT, name), os.path.join(path, name))
    return path


def environment(ws: str) -> dict[str, str]:
    env = dict(os.environ)
    env.update(WANDB_MODE="offline", WANDB_DIR=ws, MPLBACKEND="Agg", PYTHONUNBUFFERED="1")
    # `python`, `torchrun`, `tensorboard` of this interpreter's environment, activated or not
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    env.pop("PYTHONPATH", None)  # as a user's shell: the working directory's packages, the installed ones
    return env


def run_until_stopped(argv: list[str], ws: str, env: dict, seconds: float) -> tuple[int | None, str]:
    """Start ``argv``; None when it was still running after ``seconds`` (then stopped), else its status."""
    proc = subprocess.Popen(argv, cwd=ws, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=seconds)
        return proc.returncode, out
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGINT)  # the session this test started: the command and its children
        try:
            out, _ = proc.communicate(timeout=STOP_GRACE)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, _ = proc.communicate()
        return None, out


SHELL = set("*?[]{}$~`\\'\"")  # outside quotes: globs, expansions, escapes; bash runs those lines
GLOB = set("*?[]")  # a word with these and no other shell character is itself where it matches no file
ASSIGNMENT = re.compile(r"^[A-Za-z_]\w*=")  # NAME=VALUE before a command: that command's environment


def simple_argv(command: str, cwd: str | None = None) -> list[str] | None:
    """The argv of a plain ``python ...`` / ``rlchain ...`` / ``torchrun ...`` command line, after any leading
    ``NAME=VALUE``
    assignments (no shell operator, expansion or glob that matches a file in ``cwd``: bash would run it as
    written), for the fork server; None for anything else. The assignments stay the argv's first tokens
    (split_assignments takes them off)."""
    lexer = shlex.shlex(command, posix=False, punctuation_chars=True)
    lexer.whitespace_split = True
    try:
        raw = list(lexer)
    except ValueError:
        return None
    for token in raw:
        if len(token) >= 2 and token[0] in "'\"" and token[-1] == token[0]:
            if token[0] == '"' and any(c in token[1:-1] for c in '$`\\"'):
                return None
            continue
        if all(c in "();<>|&" for c in token):
            return None
        special = SHELL & set(token)
        if special and not (cwd is not None and special <= GLOB and not glob.glob(os.path.join(cwd, token))):
            return None
    argv = shlex.split(command, comments=True)
    _, rest = split_assignments(argv)
    head = os.path.basename(rest[0]) if rest else ""
    return argv if head in ("rlchain", "torchrun") or head.startswith("python") else None


def forkable(command: str, shown: str, cwd: str | None = None) -> list[str] | None:
    """The argv of ``shown`` (``command`` shortened) for the fork server, or None where bash must run it. Checked
    on the command as written, ``<run>`` a plain word: shortening only adds plain words, but shlex.join may quote
    them (a ``python -c "..."`` comes back in single quotes). A glob that matches no file in ``cwd`` is a word,
    as bash leaves it (``params.import_modules=[mypkg]``)."""
    return shlex.split(shown) if simple_argv(command.replace("<run>", "run"), cwd) is not None else None


def split_assignments(argv: list[str]) -> tuple[dict[str, str], list[str]]:
    """(the leading ``NAME=VALUE`` assignments, the command after them)."""
    at = next((i for i, token in enumerate(argv) if not ASSIGNMENT.match(token)), len(argv))
    return dict(token.split("=", 1) for token in argv[:at]), argv[at:]


@pytest.fixture(scope="module")
def fork_server():
    """The fork server, or None where RLCHAIN_DOCS_FRESH=1 asks for every command in a fresh process."""
    if os.environ.get("RLCHAIN_DOCS_FRESH") == "1":
        yield None
        return
    server = ForkServer(environment(ROOT), STOP_GRACE, preload=("envpool",))  # three pages' MuJoCo commands
    yield server
    server.close()


_TIMES = os.environ.get("RLCHAIN_DOCS_TIMES")
"""A file to append each docs command's wall and CPU seconds to (CPU: the command and its children), with its
page, line and command: where a page's time goes."""


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(argv: list[str], ws: str, env: dict, block: Block, shown: str, server: ForkServer | None = None,
        direct: list[str] | None = None, prelude: str | None = None) -> str:
    """Run one command of ``block``: ``direct`` (the command's argv, a plain python / rlchain command) through
    ``server`` where both are given (its child calls ``prelude`` first), else ``argv``; check its status; returns
    its output."""
    if not _TIMES:
        return _run(argv, ws, env, block, shown, server, direct, prelude)
    wall, cpu = time.perf_counter(), _children_cpu()
    if server is not None:
        server.last_cpu = 0.0
    try:
        return _run(argv, ws, env, block, shown, server, direct, prelude)
    finally:
        spent = _children_cpu() - cpu + (server.last_cpu if server is not None else 0.0)
        with open(_TIMES, "a", encoding="utf-8") as fh:
            fh.write(f"{time.perf_counter() - wall:.2f}\t{spent:.2f}\t{block.where}\t{shown[:200]}\n")


def _run(argv: list[str], ws: str, env: dict, block: Block, shown: str, server: ForkServer | None,
         direct: list[str] | None, prelude: str | None = None) -> str:
    timeout = block.options.get("timeout")
    if server is None:
        direct = None
    elif direct is None and argv[0] == sys.executable:
        direct = argv
    if direct is not None:
        assignments, direct = split_assignments(direct)
        env = {**env, **assignments}
    if timeout is not None:
        if direct is not None:
            status, stdout, stderr = server.run(direct, ws, env, COMMAND_TIMEOUT, float(timeout), prelude)
            out = stdout + stderr
        else:
            status, out = run_until_stopped(argv, ws, env, float(timeout))
        assert status is None and "Traceback" not in out, (
            f"{block.where}: `{shown}` should still run after {timeout} s, but it ended with status {status}:\n"
            f"{out[-3000:]}")
        return out
    if direct is not None:
        status, stdout, stderr = server.run(direct, ws, env, COMMAND_TIMEOUT, prelude=prelude)
    else:
        proc = subprocess.run(argv, cwd=ws, env=env, capture_output=True, text=True, timeout=COMMAND_TIMEOUT,
                              start_new_session=True)
        status, stdout, stderr = proc.returncode, proc.stdout, proc.stderr
    expected = int(block.options.get("status", 0))
    assert status == expected, (
        f"{block.where}: `{shown}` exited with {status}, expected {expected}:\n{stdout[-3000:]}\n{stderr[-3000:]}")
    return stdout + stderr


def check_output(block: Block, out: str) -> None:
    for line in block.text.splitlines():
        for part in (p.strip() for p in line.split("...")):
            assert part in out, f"{block.where}: '{part}' is not in the output of the command before it:\n{out[-3000:]}"


def runnable_pages() -> list[str]:
    return [page for page in PAGES if any(b.kind in ("run", "file") for b in read_blocks(page))]


@pytest.mark.timeout(900)
@pytest.mark.parametrize("page", runnable_pages())
def test_page_commands_run(page, tmp_path, fork_server):
    ws = workspace(str(tmp_path / "ws"))
    env = environment(ws)
    blocks = read_blocks(page)
    reusable = not any(b.kind == "file" or (b.kind == "run" and b.lang in ("python", "py")) for b in blocks)
    out = ""
    for at, block in enumerate(blocks):
        if block.kind == "file":
            path = os.path.join(ws, block.args)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(block.text + "\n")
        elif block.kind == "output":
            check_output(block, out)
        elif block.kind == "run" and block.lang in ("python", "py"):
            script = os.path.join(ws, f"_docs_block_{block.line}.py")
            with open(script, "w", encoding="utf-8") as fh:
                fh.write(block.text + "\n")
            # capped as a command line is (tests/smoke/docs_caps.py): in the fork server's child, or a fresh
            # `python docs_caps.py BLOCK.py`
            out = run([sys.executable, CAPS, script], ws, env, block, f"python block at line {block.line}",
                      fork_server, [sys.executable, script], prelude=CAPS_PRELUDE)
        elif block.kind == "run" and "timeout" in block.options and not shown_output(blocks, at):
            for command in commands(block.text):  # checked by the last test: still running after N s
                shown = shorten(command, ws)
                _background.append(start_background(block, shown, ws, env, fork_server,
                                                     forkable(command, shown, ws)))
        elif block.kind == "run":
            plain = reusable and not block.options and "<run>" not in block.text
            for command in commands(block.text):
                shown = shorten(command, ws)
                if plain and shown in _ran_ok:
                    continue
                out = run(["bash", "-c", shown], ws, env, block, shown, fork_server, forkable(command, shown, ws))
                if not block.options:
                    _ran_ok.add(shown)


def shown_output(blocks: list[Block], at: int) -> bool:
    """Whether an ``output`` block follows block ``at`` (its output is checked: it runs in the foreground)."""
    return at + 1 < len(blocks) and blocks[at + 1].kind == "output"


def start_background(block: Block, shown: str, ws: str, env: dict, server: ForkServer | None,
                     direct: list[str] | None) -> docs_background.Background:
    """Start ``shown``, a command of a ``run timeout=N`` block, in the background (tests/smoke/docs_background.py):
    ``direct`` detached from the fork ``server`` where both are given, else through bash."""
    if server is not None and direct is not None:
        assignments, direct = split_assignments(direct)
        env = {**env, **assignments}
    else:
        server = direct = None
    return docs_background.start(block.where, shown, float(block.options["timeout"]), ws, env, STOP_GRACE, server,
                                 direct)


def finish_background() -> list[str]:
    """Wait for the background commands' checks; their problems (docs_background.finish), each command's wall and
    CPU seconds appended to RLCHAIN_DOCS_TIMES's file."""
    jobs = list(_background)
    problems = docs_background.finish(_background)
    if _TIMES:
        with open(_TIMES, "a", encoding="utf-8") as fh:
            for job in jobs:
                fh.write(f"{job.wall:.2f}\t{job.cpu:.2f}\t{job.where}\t{job.shown[:200]} (background)\n")
    return problems


def test_a_background_command_must_still_run_at_its_time(tmp_path, fork_server):
    """The background check bites: a command that ends before its time is reported, one that runs on is not."""
    env = environment(str(tmp_path))
    block = Block("x.md", 3, "bash", "", "run", "timeout=1", {"timeout": "1"})
    ends = "python -c 'import sys; sys.exit(3)'"
    jobs = [start_background(block, "sleep 30", str(tmp_path), env, fork_server, None),
            start_background(block, ends, str(tmp_path), env, fork_server, forkable(ends, ends))]
    problems = docs_background.finish(jobs)
    assert len(problems) == 1 and problems[0].startswith(f"x.md:3: `{ends}` should still run after 1 s, but it "
                                                         f"ended within"), problems


def test_commands_that_run_until_stopped_ran_on():
    """After the pages (tests run in file order): each ``run timeout=N`` command the pages started was still
    running N s after its start, with no traceback in its output (a page run alone: checked at the module's end)."""
    problems = finish_background()
    assert not problems, "\n".join(problems)


@pytest.fixture(scope="module", autouse=True)
def background_commands_checked():
    """A background command whose page ran without the test above (``-k``) is checked when the module ends."""
    yield
    problems = finish_background()
    assert not problems, "\n".join(problems)
