"""The documentation site: it builds strictly and offline, and the API it shows is documented.

- ``mkdocs build --strict`` (mkdocs.yml at the repository root): a broken link, a missing page, a
  page left out of the nav or a link to a missing anchor fails the build;
- the built pages load nothing from the network (no fonts, scripts or styles from elsewhere);
- every public function, class and method of the objects docs/api.md renders (its ``:::`` lines)
  has a docstring of its own;
- every plot under docs/img/ is shown by a page (benchmark results live outside git);
- the README's test command is the one .ci/run runs, and every extra a ``pip install`` line in the
  docs names exists in setup.py.
"""

from __future__ import annotations

import ast
import dataclasses
import glob
import importlib
import inspect
import os
import re
import subprocess
import sys
import types

import pytest

from tests.conftest import ROOT

DOCS = os.path.join(ROOT, "docs")
# the public Python API the site must document; docs/api.md may show more
REQUIRED_API = {
    "rlchain.Runner", "rlchain.model_builder", "rlchain.networks.NetworkBuilder", "rlchain.training.events.Callback",
    "rlchain.inference.export.onnx.OnnxPolicy", "rlchain.envs.vecenv", "rlchain.algos.base.algorithm.Algorithm",
    "rlchain.training.loop.Loop",
}
DOCS_PACKAGES = ("mkdocs", "mkdocs-material", "mkdocstrings")


def _read(*parts: str) -> str:
    with open(os.path.join(ROOT, *parts), encoding="utf-8") as fh:
        return fh.read()


# ----- the site builds ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """Build the site once into a temporary folder; returns the folder."""
    out = tmp_path_factory.mktemp("site")
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                           os.path.join(ROOT, "mkdocs.yml"), "--site-dir", str(out)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, ("mkdocs build --strict failed (pip install -e '.[docs]' if mkdocs is missing):\n"
                                  + proc.stdout[-5000:] + proc.stderr[-5000:])
    return str(out)


def test_site_builds_strictly_with_every_page(site):
    for page in ("index.html", "quickstart/index.html", "config/index.html", "api/index.html",
                 "benchmarks/index.html", "troubleshooting/index.html"):
        assert os.path.isfile(os.path.join(site, page)), page
    api = open(os.path.join(site, "api", "index.html"), encoding="utf-8").read()
    for name in REQUIRED_API:  # mkdocstrings rendered each object (its id is the dotted path)
        assert f'id="{name}"' in api, name


def test_site_loads_nothing_from_the_network(site):
    external = re.compile(r"""<(?:script|link|img|iframe|source)\b[^>]*\b(?:src|href)=["']?(?:https?:)?//""", re.I)
    found = []
    for path in glob.glob(os.path.join(site, "**", "*.html"), recursive=True):
        with open(path, encoding="utf-8") as fh:
            found += [f"{os.path.relpath(path, site)}: {m.group(0)}" for m in external.finditer(fh.read())]
    assert not found, "pages load from the network:\n" + "\n".join(found[:20])


def test_every_committed_plot_is_shown_by_a_page(site):
    """Benchmark results go to benchmarks/results/ (outside git); docs/img/ holds only plots a page shows or links."""
    shown = set()
    for path in glob.glob(os.path.join(site, "**", "*.html"), recursive=True):
        with open(path, encoding="utf-8") as fh:
            shown.update(os.path.basename(src) for src in re.findall(r'\b(?:src|href)="([^"]+\.png)"', fh.read()))
    committed = [os.path.relpath(p, DOCS) for p in glob.glob(os.path.join(DOCS, "img", "**", "*.png"), recursive=True)]
    assert committed, "docs/img/ has no plots"
    unshown = [name for name in committed if os.path.basename(name) not in shown]
    assert not unshown, f"docs/img/ holds plots no page shows: {unshown}"


# ----- the API pages: every public object has a docstring ----------------------------------------
def api_targets() -> list[str]:
    return re.findall(r"^::: ([\w.]+)\s*$", _read("docs", "api.md"), flags=re.M)


def resolve(path: str):
    """Import ``a.b.c``: the longest importable module prefix, then attributes."""
    parts = path.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for name in parts[i:]:
            obj = getattr(obj, name)
        return obj
    raise ImportError(path)


def _own_doc(obj) -> str | None:
    doc = obj.__doc__
    if inspect.isclass(obj) and dataclasses.is_dataclass(obj) and doc and doc.startswith(f"{obj.__name__}("):
        return None  # the signature dataclasses write when the class has no docstring
    return doc.strip() if isinstance(doc, str) and doc.strip() else None


def public_members(obj, path: str):
    """(dotted path, object) for ``obj`` and every public function, class and method it holds
    (its own: for a module what it defines, for a class what its body defines)."""
    yield path, obj
    if isinstance(obj, types.ModuleType):
        for name, member in vars(obj).items():
            if not name.startswith("_") and (inspect.isfunction(member) or inspect.isclass(member)) \
                    and member.__module__ == obj.__name__:
                yield from public_members(member, f"{path}.{name}")
    elif inspect.isclass(obj):
        for name, member in vars(obj).items():
            if name.startswith("_"):
                continue
            if isinstance(member, (staticmethod, classmethod)):
                member = member.__func__
            elif isinstance(member, property):
                member = member.fget
            if inspect.isfunction(member) or inspect.isclass(member):
                yield from public_members(member, f"{path}.{name}")


def undocumented(paths: list[str]) -> list[str]:
    return [name for path in paths for name, obj in public_members(resolve(path), path) if _own_doc(obj) is None]


def test_api_page_covers_the_public_api():
    missing = REQUIRED_API - set(api_targets())
    assert not missing, f"docs/api.md does not render {sorted(missing)}"


def test_every_public_object_on_the_api_page_has_a_docstring():
    missing = undocumented(api_targets())
    assert not missing, "public API without a docstring (add one):\n" + "\n".join(missing)


def test_the_docstring_walk_finds_what_lacks_one():
    module = types.ModuleType("fake_api")

    class Documented:
        """Has one."""

        def method(self):
            """Has one."""

        def bare(self):
            pass

        @property
        def prop(self):
            return 1

        def _private(self):
            pass

    def function():
        pass

    Documented.__module__ = function.__module__ = "fake_api"
    module.Documented, module.function = Documented, function
    sys.modules["fake_api"] = module
    try:
        assert sorted(undocumented(["fake_api"])) == ["fake_api", "fake_api.Documented.bare",
                                                      "fake_api.Documented.prop", "fake_api.function"]
    finally:
        del sys.modules["fake_api"]


# ----- install commands ------------------------------------------------------------------------
def _extras() -> set[str]:
    tree = ast.parse(_read("setup.py"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "EXTRAS" for t in node.targets):
            return {ast.literal_eval(key) for key in node.value.keys} | {"all"}
    raise AssertionError("setup.py has no EXTRAS dict")


def test_readme_test_command_is_what_ci_runs():
    readme = _read("README.md").splitlines()
    assert readme[2] == "```bash" and readme[7] == "```", "the fresh-machine commands are README lines 3-8"
    ci = _read(".ci", "run").splitlines()
    command = ci[ci.index("# --- the README's test command (keep the two identical) ---") + 1]
    assert readme[6].endswith(command), f"README line 7 and .ci/run differ:\n{readme[6]}\n{command}"


def test_docs_install_only_extras_that_exist():
    extras = _extras()
    pages = ["README.md", "notebooks/README.md"]
    pages += [os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(DOCS, "*.md"))]
    named = {(page, extra.strip()) for page in pages
             for group in re.findall(r'pip install[^\n`]*?-e "?\.\[([\w,\s-]+)\]', _read(page))
             for extra in group.split(",")}
    assert named, "no pip install -e .[extra] line found"
    unknown = sorted(f"{page}: {extra}" for page, extra in named if extra not in extras)
    assert not unknown, f"extras not in setup.py: {unknown}"


def test_docs_packages_are_in_the_test_extra_and_pinned():
    tree = ast.parse(_read("setup.py"))
    extras = next(ast.literal_eval(node.value) for node in ast.walk(tree) if isinstance(node, ast.Assign)
                  and any(getattr(t, "id", None) == "EXTRAS" for t in node.targets))
    pins = {line.split("==")[0].lower() for line in _read("constraints.txt").splitlines() if "==" in line}
    for package in DOCS_PACKAGES:
        for extra in ("docs", "test"):
            assert any(re.match(rf"{package}(\[|$|[<>=!~])", dep) for dep in extras[extra]), (package, extra)
        assert package in pins, f"{package} is not pinned in constraints.txt"
