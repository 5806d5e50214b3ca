"""Nothing only passes a call on: few methods or properties whose body only returns (or calls) the
same-named member of an attribute (``def save(self, kind): return self.checkpoints.save(kind)``), and no
``__getattr__`` / ``__setattr__`` that hands attribute access to another object.

The peers' faces (``rl_games/``, ``sb3/``, ``rllib/``) forward by design: they give another library's names
to rlchain's objects. So do the env wrappers and backends (``envs/wrappers/``, ``envs/backends/``,
``envs/examples/``), which stand in for the env they wrap. Everything else is counted with ``ast``.
"""

from __future__ import annotations

import ast
import os

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
PACKAGE = os.path.join(ROOT, "rlchain")
FACES = ("rl_games", "sb3", "rllib", os.path.join("envs", "wrappers"), os.path.join("envs", "backends"),
         os.path.join("envs", "examples"))
MAX_FORWARDING = 8


def modules() -> list[tuple[str, ast.Module]]:
    """(path relative to rlchain/, parsed module) of every module outside the faces."""
    found = []
    for folder, _, files in os.walk(PACKAGE):
        rel = os.path.relpath(folder, PACKAGE)
        if any(rel == face or rel.startswith(face + os.sep) for face in FACES):
            continue
        for name in sorted(files):
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                with open(path, encoding="utf-8") as f:
                    found.append((os.path.normpath(os.path.join(rel, name)), ast.parse(f.read(), path)))
    return found


def forwards(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """Whether ``fn``'s body (its docstring aside) is one ``return a.b.name`` / ``a.b.name(...)``, or
    ``return``/call of them, in a def named ``name``: it only hands the call to an attribute's member."""
    body = [s for s in fn.body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant))]
    if len(body) != 1 or not isinstance(body[0], (ast.Return, ast.Expr)) or body[0].value is None:
        return False
    expr = body[0].value
    if isinstance(expr, ast.Call):
        expr = expr.func
    return isinstance(expr, ast.Attribute) and expr.attr == fn.name and isinstance(expr.value, ast.Attribute)


def forwarding_defs() -> list[str]:
    return [f"rlchain/{path}:{node.lineno} {node.name}" for path, tree in modules() for node in ast.walk(tree)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and forwards(node)]


def attribute_hooks() -> list[str]:
    """``__getattr__`` / ``__setattr__`` defined in a class (a module's lazy ``__getattr__`` is an import)."""
    return [f"rlchain/{path}:{item.lineno} {cls.name}.{item.name}" for path, tree in modules()
            for cls in ast.walk(tree) if isinstance(cls, ast.ClassDef)
            for item in cls.body if isinstance(item, ast.FunctionDef) and item.name in ("__getattr__", "__setattr__")]


def test_the_counter_finds_a_forwarding_method_and_property():
    tree = ast.parse("class A:\n"
                     "    def save(self, kind):\n        '''doc'''\n        return self.saver.save(kind)\n"
                     "    @property\n    def epoch(self):\n        return self.ctx.epoch\n"
                     "    def close(self):\n        self.env.close()\n"
                     "    def scalar(self, tag):\n        self.log.write(tag)\n"
                     "    def epoch2(self):\n        return self.ctx.epoch\n"
                     "    def step(self):\n        self.a.step()\n        self.b.step()\n")
    names = [n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef) and forwards(n)]
    assert names == ["save", "epoch", "close"]


def test_few_methods_only_forward_outside_the_faces():
    found = forwarding_defs()
    assert len(found) <= MAX_FORWARDING, "\n".join(found)


def test_no_attribute_access_is_forwarded_outside_the_faces():
    assert attribute_hooks() == []
