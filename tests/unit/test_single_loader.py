"""One loader: a file is unpickled by rlchain/runs/checkpoint.py and nowhere else, YAML is read with safe loaders
only, and a module is imported by name only at the few sites listed below, each importing a name from the user's
own config or rlchain's own constants (never from a loaded checkpoint: rlchain/config/stored.py drops those keys).

The check reads the source (AST), so a new ``torch.load`` or ``pickle.loads`` anywhere else fails here.
"""

import ast
import os

import yaml

from tests.conftest import ROOT

LOADER = "rlchain/runs/checkpoint.py"
UNPICKLERS = {"torch": {"load"}, "pickle": {"load", "loads", "Unpickler"}, "cloudpickle": {"load", "loads"},
              "dill": {"load", "loads"}, "joblib": {"load"}, "numpy": {"load"}, "np": {"load"}, "marshal": {"loads"}}
UNSAFE_YAML = {"unsafe_load", "full_load", "unsafe_load_all", "full_load_all", "Loader", "UnsafeLoader",
               "FullLoader", "load_all"}
SAFE_LOADERS = {"SafeLoader", "CSafeLoader", "BaseLoader", "NoAliasLoader", "_NoAliases"}
# every site that unpickles bytes that are not a file: they come from rlchain's own Ray worker processes
PICKLE_IPC = {
    "rlchain/envs/ray/ray_worker.py": "actions sent by the rlchain process that started the worker",
    "rlchain/envs/ray/ray_env.py": "step results returned by rlchain's own Ray workers",
}
# every site that imports a module by a name known only at run time, and where the name comes from
IMPORT_SITES = {
    "rlchain/__init__.py": "rlchain's own lazily imported names (a constant table)",
    "rlchain/console.py": "rlchain's own subcommand modules (literals)",
    "rlchain/faces.py": "a face's aliased names (rl_games.*, ray.rllib.*) mapped onto its own modules "
                        "(rlchain.rl_games.*, rlchain.rllib.*)",
    "rlchain/errors.py": "optional dependencies (optional_import), by the literal names of their callers "
                         "(optuna, ray.tune, moviepy, wandb, envpool, ale_py, onnx, onnxruntime)",
    "rlchain/registry.py": "import_object: config.callbacks, config.events functions and config.symmetry.mirror "
                           "(module:Name) of the user's config",
    "rlchain/config/load.py": "params.import_modules and config.callbacks of the user's config (--file, dict, "
                              "overrides); a checkpoint's stored ones are dropped first",
    "rlchain/envs/backends/pettingzoo_env.py": "the PettingZoo env named by the user's config (pettingzoo.* first; a "
                                               "name PettingZoo lists is only its module; a stored name must be "
                                               "listed: rlchain/envs/known.py)",
}


def sources():
    for folder, _, names in os.walk(os.path.join(ROOT, "rlchain")):
        for name in names:
            if name.endswith(".py"):
                path = os.path.join(folder, name)
                yield os.path.relpath(path, ROOT).replace(os.sep, "/"), path
    for name in ("runner.py", "train.py", "setup.py"):
        if os.path.isfile(os.path.join(ROOT, name)):
            yield name, os.path.join(ROOT, name)


def findings(tree):
    """(kind, line, text) of every unpickling, unsafe YAML and by-name import in ``tree``."""
    imported = {}  # a bare name -> (module, attribute) for ``from pickle import loads``
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                imported[alias.asname or alias.name] = (node.module.split(".")[0], alias.name)
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            module, attr = node.value.id, node.attr
        elif isinstance(node, ast.Name) and node.id in imported and isinstance(node.ctx, ast.Load):
            module, attr = imported[node.id]
        elif isinstance(node, ast.Call):
            yield from _call(node)
            continue
        else:
            continue
        if attr in UNPICKLERS.get(module, ()):
            yield "unpickle", node.lineno, f"{module}.{attr}"
        if module == "yaml" and attr in UNSAFE_YAML:
            yield "yaml", node.lineno, f"yaml.{attr}"
        if module == "importlib" and attr in ("import_module", "__import__"):
            yield "import", node.lineno, f"importlib.{attr}"
        if module in ("importlib", "util") and attr in ("spec_from_file_location", "module_from_spec"):
            yield "import", node.lineno, f"importlib.util.{attr}"


def _call(node):
    func = node.func
    if isinstance(func, ast.Name) and func.id in ("__import__", "exec", "eval", "import_module"):
        yield ("import" if func.id != "eval" and func.id != "exec" else "exec"), node.lineno, func.id
    if isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name) and func.value.id == "yaml" \
            and func.attr == "load":
        loader = next((k.value for k in node.keywords if k.arg == "Loader"), None)
        name = getattr(loader, "id", None) or getattr(loader, "attr", None)
        if name not in SAFE_LOADERS:
            yield "yaml", node.lineno, f"yaml.load(Loader={name})"


def test_files_are_unpickled_by_the_checkpoint_module_only():
    bad = []
    for rel, path in sources():
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), rel)
        for kind, line, text in findings(tree):
            if kind == "unpickle" and (rel == LOADER or (rel in PICKLE_IPC and text.startswith("pickle."))):
                continue
            if kind == "import" and rel in IMPORT_SITES:
                continue
            bad.append(f"{rel}:{line}: {text}")
    assert not bad, ("load files through rlchain.runs.checkpoint (read / load), YAML with yaml.safe_load, and "
                     "import modules only at the listed sites:\n" + "\n".join(bad))


def test_the_listed_sites_still_exist_and_the_yaml_loader_is_safe():
    from rlchain.compare.files import _NoAliases
    from rlchain.config.text import NoAliasLoader

    assert issubclass(NoAliasLoader, yaml.SafeLoader) and issubclass(_NoAliases, yaml.SafeLoader)
    for rel in [*PICKLE_IPC, *IMPORT_SITES]:
        with open(os.path.join(ROOT, rel), encoding="utf-8") as fh:
            kinds = {kind for kind, _, _ in findings(ast.parse(fh.read(), rel))}
        assert kinds & {"unpickle", "import"}, f"{rel} no longer imports or unpickles: drop it from the list"
    with open(os.path.join(ROOT, LOADER), encoding="utf-8") as fh:
        assert ("unpickle", "torch.load") in {(k, t) for k, _, t in findings(ast.parse(fh.read()))}


def test_the_check_sees_what_it_forbids():
    code = ("import torch, pickle, yaml, importlib\nfrom pickle import loads\n"
            "torch.load('x')\npickle.loads(b'')\nloads(b'')\nyaml.load('a')\nyaml.unsafe_load('a')\n"
            "yaml.load('a', Loader=yaml.SafeLoader)\nimportlib.import_module(name)\n__import__(name)\n")
    got = sorted(text for _, _, text in findings(ast.parse(code)))
    assert got == sorted(["torch.load", "pickle.loads", "pickle.loads", "yaml.load(Loader=None)", "yaml.unsafe_load",
                          "importlib.import_module", "__import__"]), got
