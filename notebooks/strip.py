"""Strip outputs from notebooks before committing them: ``python notebooks/strip.py [--check] [FILE ...]``.

Clears every code cell's outputs and execution count, drops per-run metadata (cell timings,
widget state, Colab's per-session keys) and writes the notebook back in nbformat's own layout
(one-space indent, sorted keys), so a stripped notebook diffs cleanly. Without files it strips
every ``*.ipynb`` next to this script. ``--check`` changes nothing and exits 1 if a file would
change (for CI or a pre-commit hook). Needs only the standard library.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys

CELL_KEYS = ("execution", "ExecuteTime", "collapsed", "scrolled", "outputId", "colab")
NOTEBOOK_KEYS = ("widgets", "colab", "accelerator", "gpuClass")


def strip(nb: dict) -> dict:
    """Return ``nb`` (a notebook's JSON) without outputs, execution counts and run metadata."""
    for cell in nb.get("cells", []):
        if cell.get("cell_type") == "code":
            cell["outputs"] = []
            cell["execution_count"] = None
        meta = cell.get("metadata", {})
        for key in CELL_KEYS:
            meta.pop(key, None)
    meta = nb.get("metadata", {})
    for key in NOTEBOOK_KEYS:
        meta.pop(key, None)
    if "language_info" in meta:  # the kernel writes its Python version, pygments lexer, ... on every run
        meta["language_info"] = {"name": meta["language_info"].get("name", "python")}
    return nb


def dumps(nb: dict) -> str:
    """nbformat's layout: what ``nbformat.write`` produces, so both agree byte for byte."""
    return json.dumps(nb, indent=1, sort_keys=True, ensure_ascii=False) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", help="notebooks (default: notebooks/*.ipynb)")
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if a file is not stripped")
    args = parser.parse_args(argv)
    files = args.files or sorted(glob.glob(os.path.join(os.path.dirname(os.path.abspath(__file__)), "*.ipynb")))
    dirty = []
    for path in files:
        with open(path, encoding="utf-8") as f:
            text = f.read()
        stripped = dumps(strip(json.loads(text)))
        if stripped == text:
            continue
        dirty.append(path)
        if not args.check:
            with open(path, "w", encoding="utf-8") as f:
                f.write(stripped)
    for path in dirty:
        print(f"{'not stripped' if args.check else 'stripped'}: {path}")
    return 1 if args.check and dirty else 0


if __name__ == "__main__":
    sys.exit(main())
