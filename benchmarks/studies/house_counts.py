"""The size of the package, counted the way the house reviews count it (read with ``ast``, no import).

    python benchmarks/studies/house_counts.py [ROOT ...]   # ROOT: a checkout (default: this one)

For each checkout it prints:

- ``code_lines``: lines of ``rlchain/**/*.py`` holding code: not blank, not a comment, not part of a string
  that stands alone as a statement (module / class / function docstrings and the attribute docstrings under
  constants); ``modules``: how many ``.py`` files;
- ``public_names``: top-level functions and classes of every module whose name does not start with ``_``;
  ``public_constants``: top-level assigned names that do not start with ``_``;
- ``forwarding_defs``: functions and methods whose whole body (docstring aside) only calls or returns the
  same-named member of an attribute (``def epoch(self): return self.loop.epoch``, ``def close(self):
  self.env.close()``; a property's forwarding setter counts with its getter, once), counted outside the
  compatibility faces (``rlchain/rl_games/``, ``rlchain/sb3/``) and the env wrappers and backends
  (``rlchain/envs/``), which forward by design; ``forwarding_defs_all`` counts them everywhere;
- ``zero_grad_modules``: modules under ``rlchain/algos/`` that call ``zero_grad``;
- ``rl_games_checkpoint_lines``: ``wc -l rlchain/runs/rl_games_*.py``.
"""

from __future__ import annotations

import argparse
import ast
import io
import json
import os
import tokenize
from pathlib import Path

FACES = ("rlchain/rl_games/", "rlchain/sb3/", "rlchain/envs/")
SKIP_TOKENS = {tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT,
               tokenize.ENDMARKER, tokenize.ENCODING}


def doc_lines(tree: ast.AST) -> set[int]:
    """Line numbers of strings that stand alone as statements (docstrings, attribute docstrings)."""
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            lines.update(range(node.lineno, node.end_lineno + 1))
    return lines


def code_lines(source: str, tree: ast.AST) -> int:
    """Lines with a token other than a comment, inside no standalone string."""
    docs = doc_lines(tree)
    lines: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type in SKIP_TOKENS:
            continue
        lines.update(n for n in range(tok.start[0], tok.end[0] + 1) if n not in docs)
    return len(lines)


def public_names(tree: ast.Module) -> tuple[int, int]:
    """(top-level functions and classes, top-level assigned names), those not starting with ``_``."""
    defs, assigned = set(), set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            defs.add(node.name)
        elif isinstance(node, ast.Assign):
            assigned.update(t.id for t in node.targets if isinstance(t, ast.Name))
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            assigned.add(node.target.id)
    return tuple(sum(1 for name in names if not name.startswith("_")) for names in (defs, assigned))


def _forwards(node: ast.AST, name: str) -> bool:
    """``node`` is ``<x>.<attr>.name``: the member ``name`` of an attribute (not of a module or a local)."""
    return isinstance(node, ast.Attribute) and node.attr == name and isinstance(node.value, ast.Attribute)


def is_forwarding(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """Whether ``fn``'s body only calls, returns or sets the same-named member of an attribute."""
    body = list(fn.body)
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        body = body[1:]  # the docstring
    if len(body) != 1:
        return False
    stmt = body[0]
    value = stmt.value if isinstance(stmt, (ast.Return, ast.Expr)) else None
    if isinstance(stmt, ast.Assign) and len(stmt.targets) == 1:  # a setter: self.loop.epoch = value
        target = stmt.targets[0]
        return _forwards(target, fn.name)
    if isinstance(value, ast.Call):
        value = value.func
    return value is not None and _forwards(value, fn.name)


def _is_setter(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """``@<name>.setter``: counted with its property's getter."""
    return any(isinstance(d, ast.Attribute) and d.attr == "setter" for d in fn.decorator_list)


def forwarding_defs(tree: ast.Module) -> int:
    """Functions and methods (at any depth) that only forward (see :func:`is_forwarding`)."""
    return sum(1 for node in ast.walk(tree) if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
               and not _is_setter(node) and is_forwarding(node))


def calls_zero_grad(tree: ast.Module) -> bool:
    """Whether the module calls ``<x>.zero_grad(...)``."""
    return any(isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "zero_grad"
               for node in ast.walk(tree))


def count(root: Path) -> dict[str, int]:
    """Every figure of the module docstring for the checkout at ``root``."""
    totals = dict.fromkeys(("code_lines", "modules", "public_names", "public_constants", "forwarding_defs",
                            "forwarding_defs_all", "zero_grad_modules", "rl_games_checkpoint_lines"), 0)
    for path in sorted((root / "rlchain").rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        source = path.read_text(encoding="utf-8")
        tree = ast.parse(source, filename=rel)
        totals["modules"] += 1
        totals["code_lines"] += code_lines(source, tree)
        defs, constants = public_names(tree)
        totals["public_names"] += defs
        totals["public_constants"] += constants
        forwards = forwarding_defs(tree)
        totals["forwarding_defs_all"] += forwards
        if not rel.startswith(FACES):
            totals["forwarding_defs"] += forwards
        if rel.startswith("rlchain/algos/") and calls_zero_grad(tree):
            totals["zero_grad_modules"] += 1
        if rel.startswith("rlchain/runs/rl_games_"):
            totals["rl_games_checkpoint_lines"] += source.count("\n")
    return totals


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("roots", nargs="*", default=[os.getcwd()], help="checkouts to count (default: this directory)")
    args = ap.parse_args()
    rows = {root: count(Path(root)) for root in args.roots}
    keys = list(next(iter(rows.values())))
    width = max(len(k) for k in keys)
    print(f"{'':{width}}  " + "  ".join(f"{root:>12}" for root in rows))
    for key in keys:
        print(f"{key:{width}}  " + "  ".join(f"{row[key]:>{max(12, len(root))}}" for root, row in rows.items()))
    if len(rows) > 1:
        print(json.dumps(rows))


if __name__ == "__main__":
    main()
