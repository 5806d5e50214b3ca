"""The import graph of rlchain (docs/layout.md): imports point down, never circle, and an import inside a
function is there only for an optional dependency, saying which (``# optional: ray``).

Walks every module with ``ast`` (module-level and function-level imports, relative ones resolved), so it
runs nothing of them; it imports rlchain only for the registry of algorithms, whose packages are the families.
"""

from __future__ import annotations

import ast
import functools
import os
import re
from dataclasses import dataclass

import rlchain  # noqa: F401  (registers the built-in algorithms, whose packages are the families)
from rlchain.registry import ALGOS, Registry

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
PACKAGE = os.path.join(ROOT, "rlchain")

# the drivers: they may import the Runner (rlchain/runner.py) and the CLI; nothing else may
# (the console script rlchain.console and python -m rlchain's rlchain.__main__ included). rlchain.rl_games
# (rl_games' Python API names: its Runner drives rlchain's) is a facade at the same layer as cli.py / runner.py
ENTRY_POINTS = ("rlchain.cli", "rlchain.console", "rlchain.__main__", "rlchain.runner",
                "rlchain.tuning", "rlchain.rl_games", "rlchain.sb3", "rlchain.rllib")  # and rlchain (rlchain.Runner)
# The loop holds its algorithm (composition): algos/ imports no training/, and training/ names no family.
# Both import algos/base/ (the Algorithm protocol, the RunContext, the safety checks, episodes).
ALGO_BASE = "rlchain.algos.base"
GROUND_FLOOR = ("rlchain.errors", "rlchain.log", "rlchain.registry")  # import nothing of rlchain above them
TORCH_MODULES = ("torch", "tensorboard", "jax", "numpy.typing")  # config/ stays importable without them
OPTIONAL = re.compile(r"#\s*optional:\s*\S")


@dataclass(frozen=True)
class Import:
    importer: str
    imported: str
    line: int
    in_function: bool
    text: str


@functools.cache
def modules() -> dict[str, str]:
    """rlchain's modules by dotted name -> file (walked on first use: every pytest process collects this file,
    and parsing the package costs seconds)."""
    found = {}
    for folder, _, files in os.walk(PACKAGE):
        for name in files:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                parts = os.path.relpath(path, ROOT)[:-3].split(os.sep)
                if parts[-1] == "__init__":
                    parts = parts[:-1]
                found[".".join(parts)] = path
    return found


def algo_families(algos: Registry = ALGOS) -> tuple[str, ...]:
    """The algorithm families: the package under ``rlchain.algos`` of every registered algorithm class and
    every other folder there (multi_policy is picked by config.multi_agent, not by name); algos/base/ and
    algos/core/ are what they share, not families."""
    found = {".".join(m.split(".")[:3]) for m in modules() if m.startswith("rlchain.algos.") and m.count(".") >= 2}
    for name in algos.names():
        module = getattr(algos.get(name), "__module__", "")
        if module.startswith("rlchain.algos."):
            found.add(".".join(module.split(".")[:3]))
    return tuple(sorted(found - {ALGO_BASE, "rlchain.algos.core"}))


def _resolve(name: str) -> str | None:
    """The rlchain module ``name`` names (a module, or a package's attribute -> the package)."""
    while name and name not in modules():
        name = name.rpartition(".")[0]
    return name or None


def _imports_of(module: str, path: str) -> list[Import]:
    source = open(path).read()
    lines = source.splitlines()
    is_package = path.endswith("__init__.py")
    found: list[Import] = []

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inside = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            names: list[str] = []
            if isinstance(child, ast.Import):
                names = [alias.name for alias in child.names]
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    package = module.split(".") if is_package else module.split(".")[:-1]
                    package = package[:len(package) - (child.level - 1)]
                    base = ".".join(package + ([base] if base else []))
                names = [f"{base}.{alias.name}" for alias in child.names]  # a submodule, or base's attribute
            for name in names:
                target = _resolve(name) if name.split(".")[0] == "rlchain" else name
                if target and target != module:
                    found.append(Import(module, target, child.lineno, in_function,
                                        lines[child.lineno - 1]))
            visit(child, inside)

    visit(ast.parse(source, path), False)
    return found


@functools.cache
def imports() -> tuple[Import, ...]:
    """Every import statement of rlchain's modules, module level and inside functions."""
    return tuple(imp for module, path in modules().items() for imp in _imports_of(module, path))


def _under(module: str, *prefixes: str) -> bool:
    return any(module == p or module.startswith(p + ".") for p in prefixes)


def _family(module: str, families: tuple[str, ...]) -> str | None:
    return next((f for f in families if _under(module, f)), None)


def layer_violation(importer: str, imported: str, families: tuple[str, ...] | None = None) -> str | None:
    """Why ``importer`` may not import ``imported`` (docs/layout.md), or None; ``families``: the algorithm
    families (default: :func:`algo_families` of the registered algorithms)."""
    families = algo_families() if families is None else families
    if imported.split(".")[0] != "rlchain":
        if _under(importer, "rlchain.config") and imported.split(".")[0] in TORCH_MODULES:
            return "config/ imports no torch module"
        return None
    if _under(imported, "rlchain.runner", "rlchain.cli") and \
            not (importer == "rlchain" or _under(importer, *ENTRY_POINTS)):
        return "only entry points import runner.py / cli.py"
    if _under(imported, "rlchain.rl_games") and not _under(importer, "rlchain.rl_games"):
        return "rlchain.rl_games (rl_games' names on rlchain) is a facade on top: nothing of rlchain imports it"
    if _under(importer, "rlchain.algos", "rlchain.models", "rlchain.networks"):
        if _under(imported, "rlchain.training"):
            return "algos/, models/, networks/ import no training/ (the loop holds the algorithm)"
        if _under(imported, "rlchain.inference", "rlchain.tuning", "rlchain.builtins"):
            return "algos/, models/, networks/ sit below inference/ and tuning/"
        if _under(imported, "rlchain.runs") and _family(importer, families) is None:
            return "algos/core/, models/, networks/ write no run output"
    if _under(importer, "rlchain.models", "rlchain.networks", "rlchain.algos.core") and \
            _under(imported, "rlchain.algos") and not _under(imported, "rlchain.algos.core"):
        return "models/, networks/ and algos/core/ import no algorithm family"
    if _under(importer, ALGO_BASE) and _family(imported, families) is not None:
        return "algos/base/ (what the loop and every algorithm share) names no algorithm family"
    if _under(importer, "rlchain.envs") and not _under(imported, "rlchain.envs", "rlchain.config", "rlchain.parallel",
                                                       *GROUND_FLOOR):
        return "envs/ imports only envs/, config/, parallel/ and the ground floor"
    if _under(importer, "rlchain.config") and not _under(imported, "rlchain.config", *GROUND_FLOOR):
        return "config/ imports only config/ and the ground floor"
    if _under(importer, "rlchain.parallel") and not _under(imported, "rlchain.parallel", "rlchain.config",
                                                           *GROUND_FLOOR):
        return "parallel/ is low: it imports only config/ and the ground floor"
    if _under(importer, *GROUND_FLOOR) and not _under(imported, *GROUND_FLOOR):
        return "the ground floor (errors, log, registry) imports nothing of rlchain above it"
    if _under(importer, "rlchain.training") and not _under(imported, ALGO_BASE) and \
            _under(imported, "rlchain.algos", "rlchain.inference", "rlchain.tuning", "rlchain.builtins"):
        return "training/ names no algorithm (and nothing of inference/, tuning or the built-ins)"
    if _under(importer, "rlchain.runs") and _under(imported, "rlchain.algos", "rlchain.inference", "rlchain.tuning",
                                                   "rlchain.builtins", "rlchain.training", "rlchain.policy"):
        return "runs/ sits below the loop, the algorithms and the policy"
    if _under(importer, "rlchain.policy") and _under(imported, "rlchain.training", "rlchain.inference",
                                                     "rlchain.tuning", "rlchain.builtins", "rlchain.algos"):
        return "policy/ (a trained policy, its play loop) sits below training/, inference/ and algos/ (all of it)"
    if _under(importer, "rlchain.models", "rlchain.networks", "rlchain.algos.core", ALGO_BASE, "rlchain.envs",
              "rlchain.config", "rlchain.parallel") and _under(imported, "rlchain.policy"):
        return "models/, networks/, algos/core/, algos/base/, envs/, config/ and parallel/ sit below policy/"
    if _under(importer, "rlchain.inference") and (_family(imported, families) is not None
                                                   or _under(imported, "rlchain.training", "rlchain.tuning")):
        return "inference/ imports no algorithm, nothing of training/ and no tuning"
    return None


def _rlchain(imp: Import) -> bool:
    return imp.imported.split(".")[0] == "rlchain"


def test_no_upward_import():
    families = algo_families()
    bad = [f"{imp.importer}:{imp.line} imports {imp.imported}: {why}" for imp in imports()
           if (why := layer_violation(imp.importer, imp.imported, families)) is not None]
    assert not bad, "imports that break the layers (docs/layout.md):\n" + "\n".join(sorted(set(bad)))


def find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph ``edges`` as [a, b, ..., a], or None."""
    state: dict[str, int] = {}  # 1: on the stack, 2: done
    stack: list[str] = []

    def walk(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (cycle := walk(nxt)) is not None:
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state and (cycle := walk(node)) is not None:
            return cycle
    return None


def _edges() -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {}
    for imp in imports():
        if _rlchain(imp):
            edges.setdefault(imp.importer, set()).add(imp.imported)
    return edges


def test_no_import_cycle():
    cycle = find_cycle(_edges())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_function_level_imports_are_for_optional_dependencies_only():
    late = [f"{imp.importer}:{imp.line}: {imp.text.strip()}" for imp in imports()
            if imp.in_function and _rlchain(imp) and not OPTIONAL.search(imp.text)]
    assert not late, ("imports of rlchain modules inside functions: move them to the top of the module, or say "
                      "which optional dependency they defer (# optional: ray):\n" + "\n".join(sorted(set(late))))


def test_the_checks_bite():
    assert layer_violation("rlchain.algos.core.returns", "rlchain.training.loop")
    assert layer_violation("rlchain.models.normalization", "rlchain.training.loop")
    assert layer_violation("rlchain.training.loop", "rlchain.algos.ppo.ppo")
    assert layer_violation("rlchain.envs.factory", "rlchain.models.actor_critic")
    assert layer_violation("rlchain.inference.player", "rlchain.algos.appo.appo")
    assert layer_violation("rlchain.training.loop", "rlchain.runner")
    assert layer_violation("rlchain.training.loop", "rlchain.rl_games.torch_runner")
    assert layer_violation("rlchain.cli", "rlchain.rl_games.common.vecenv")
    assert layer_violation("rlchain.rl_games.torch_runner", "rlchain.runner") is None  # the facade drives it
    assert layer_violation("rlchain.config.params", "torch")
    assert layer_violation("rlchain.algos.core.storage", "rlchain.algos.ppo.agent")
    assert layer_violation("rlchain.algos.ppo.ppo", "rlchain.training.loop")
    assert layer_violation("rlchain.algos.multi_policy.snapshots", "rlchain.training.events")
    assert layer_violation("rlchain.algos.base.context", "rlchain.algos.ppo.agent")
    assert layer_violation("rlchain.runs.logging", "rlchain.training.events")
    assert layer_violation("rlchain.policy.play", "rlchain.training.events")
    assert layer_violation("rlchain.policy.play", "rlchain.inference.player")
    assert layer_violation("rlchain.policy.play", "rlchain.algos.base.episodes")  # game_outcome lives in envs/
    assert layer_violation("rlchain.inference.video", "rlchain.training.events")  # the callback is training/'s
    assert layer_violation("rlchain.inference.video", "rlchain.training.callback_context")
    assert layer_violation("rlchain.training.env_events", "rlchain.inference.video")
    assert layer_violation("rlchain.training.env_events", "rlchain.policy.recording") is None
    assert layer_violation("rlchain.models.build", "rlchain.policy.stepper")
    assert layer_violation("rlchain.training.evaluation", "rlchain.policy.play") is None
    assert layer_violation("rlchain.algos.distill.teacher", "rlchain.policy.play") is None
    assert layer_violation("rlchain.algos.ppo.ppo", "rlchain.algos.base.algorithm") is None
    assert layer_violation("rlchain.training.loop", "rlchain.algos.base.algorithm") is None
    assert layer_violation("rlchain.registry", "rlchain.config.errors")
    assert layer_violation("rlchain.registry", "rlchain.errors") is None  # the did-you-mean lives there
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None
