"""The env is stepped in one place per family: outside the envs themselves (``rlchain/envs/``, and the RLlib
face's stand-ins for RLlib's env wrappers, ``rlchain/rllib/env/wrappers/``, each an env stepping the game it
wraps) only the on-policy collector, the off-policy stepper and the play loop call ``step`` (or ``send`` /
``recv``, the pipelined step) on an env.

Reads every module with ``ast`` (runs nothing): a call ``<receiver>.step(...)`` whose receiver's last name
says env (``env``, ``self.env``, ``trainer.env``, ``vec_env``, ...) is an env step.
"""

from __future__ import annotations

import ast
import os
import re

PACKAGE = os.path.join(os.path.dirname(__file__), "..", "..", "rlchain")
ALLOWED = {"algos/core/collector.py", "algos/core/stepper.py", "policy/play.py"}
ENVS = ("envs/", "rllib/env/wrappers/")  # envs: a wrapper steps the env it wraps
STEPS = {"step", "send", "recv"}
ENV_NAME = re.compile(r"env", re.IGNORECASE)


def _receiver_name(node: ast.expr) -> str:
    """The last name of a call's receiver: ``env`` for ``self.env`` or ``env``; '' for anything else."""
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Name):
        return node.id
    return ""


def env_steps(source: str) -> list[int]:
    """Lines of ``source`` that step an env."""
    return [node.lineno for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in STEPS
            and ENV_NAME.search(_receiver_name(node.func.value))]


def stepping_modules() -> dict[str, list[int]]:
    """Module (path under rlchain/) -> its env-step lines, for every module outside envs/ that steps an env."""
    found = {}
    for folder, _, files in os.walk(PACKAGE):
        for name in files:
            path = os.path.join(folder, name)
            rel = os.path.relpath(path, PACKAGE).replace(os.sep, "/")
            if not name.endswith(".py") or rel.startswith(ENVS):
                continue
            with open(path) as f:
                source = f.read()
            if not any(f".{name}(" in source for name in STEPS):  # most modules: nothing to parse
                continue
            lines = env_steps(source)
            if lines:
                found[rel] = lines
    return found


def test_the_env_is_stepped_by_the_collector_the_stepper_and_the_play_loop_only():
    found = stepping_modules()
    others = {module: lines for module, lines in found.items() if module not in ALLOWED}
    assert not others, ("the env is stepped outside the collector, the off-policy stepper and the play loop "
                        f"(give them a hook instead): {others}")
    assert set(found) == ALLOWED  # each of the three still steps it (the check sees their calls)


def test_the_check_sees_the_ways_an_env_is_stepped():
    source = ("self.env.step(a)\nenv.step(a)\ntrainer.env.step(a)\nself.vec_env.send(0, a)\nenv.recv(0)\n"
              "self.optimizer.step()\nself.tracker.step(r)\nloop.step(m)\n")
    assert env_steps(source) == [1, 2, 3, 4, 5]
