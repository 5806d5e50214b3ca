"""No file of the project holds a merge-conflict marker: a marker committed by mistake (as one once was in
CHANGELOG.md) breaks docs silently and Python files loudly, so it is caught here in milliseconds."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SUFFIXES = {".py", ".md", ".yaml", ".yml", ".json", ".toml", ".cfg", ".txt", ".sh", ".rst"}
SKIP = {".git", ".venv", "venv", "runs", "nn", "build", "dist", "__pycache__", ".pytest_cache", ".ruff_cache"}
MARKERS = ("<<<<<<< ", ">>>>>>> ")


def _files():
    stack = [ROOT]
    while stack:
        folder = stack.pop()
        for path in folder.iterdir():
            if path.is_dir():
                if path.name not in SKIP and not path.name.endswith(".egg-info") and not path.is_symlink():
                    stack.append(path)
            elif path.suffix in SUFFIXES or path.name in {"run", "CHANGELOG"}:
                yield path


def test_no_file_holds_a_merge_conflict_marker():
    found = []
    for path in _files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for number, line in enumerate(text.splitlines(), 1):
            if line.startswith(MARKERS) or line == "=======" and "<<<<<<< " in text:
                found.append(f"{path.relative_to(ROOT)}:{number}")
    assert not found, "merge-conflict markers: " + ", ".join(found)
