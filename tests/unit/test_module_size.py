"""No module of the rlchain package is over 450 lines (ARCHITECTURE.md's house rule): a longer one holds more
than one thing, and is split into modules named for each."""

from __future__ import annotations

import os

PACKAGE = os.path.join(os.path.dirname(__file__), "..", "..", "rlchain")
LIMIT = 450


def module_lengths(package: str = PACKAGE) -> dict[str, int]:
    """{path relative to the package: lines} of every ``.py`` file under ``package``."""
    lengths = {}
    for folder, _, files in os.walk(package):
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                with open(path, encoding="utf-8") as fh:
                    lengths[os.path.relpath(path, package)] = sum(1 for _ in fh)
    return lengths


def test_no_module_is_over_the_limit():
    long = {path: n for path, n in module_lengths().items() if n > LIMIT}
    assert not long, f"modules over {LIMIT} lines (split them, each part named for what it holds): " + ", ".join(
        f"rlchain/{path} ({n})" for path, n in sorted(long.items()))


def test_the_check_bites(tmp_path):
    (tmp_path / "long.py").write_text("x = 1\n" * (LIMIT + 1))
    (tmp_path / "short.py").write_text("x = 1\n")
    assert module_lengths(str(tmp_path)) == {"long.py": LIMIT + 1, "short.py": 1}
