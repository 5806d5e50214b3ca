"""docs/config.md documents every key of every config block, nested blocks included.

The sync test in test_config.py only checks that the file equals ``render()``; this one walks the
config dataclasses on its own (``dataclasses.fields``, recursively, from the types the registries
parse ``params.config`` and ``params.network`` with) and looks for each key in the file, under a
heading that names the block's full key path. A block that docs.py leaves out fails here.
"""

import dataclasses
import os
import re
import types
import typing

import pytest

import rlchain  # noqa: F401  (registers the built-in algos and networks)
from rlchain.registry import ALGOS, NETWORKS
from tests.conftest import ROOT


def _roots():
    """(key path, dataclass, a word the heading must hold): what parse_params parses each block with."""
    roots = []
    for registry, path in ((ALGOS, "params.config"), (NETWORKS, "params.network")):
        for name in registry.names():
            cls = getattr(registry.get(name), "config_class", None)
            # built-in config types only: a test may register its own builder with a config_class
            if cls is not None and cls.__module__.startswith("rlchain.config"):
                roots.append((path, cls, name))  # the heading names it (several names: "algo a / b")
    return roots


def _dataclass_in(tp):
    """The dataclass a field holds: itself, Optional of it, or a list of it; else None."""
    if dataclasses.is_dataclass(tp):
        return tp
    args = [a for a in typing.get_args(tp) if a is not type(None)]
    if typing.get_origin(tp) in (typing.Union, types.UnionType, list) and len(args) == 1:
        return _dataclass_in(args[0])
    return None


def _blocks():
    """Every (key path, dataclass, heading word) reachable from the roots; nested blocks get word ''."""
    out, todo = [], list(_roots())
    while todo:
        path, cls, word = todo.pop()
        if (path, cls, word) in out:
            continue
        out.append((path, cls, word))
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            inner = _dataclass_in(hints[f.name])
            if inner is not None:
                todo.append((f"{path}.{f.name}", inner, ""))
    return out


def _doc_sections(text):
    """heading -> (key paths the heading names, keys of its table rows)."""
    sections = {}
    for chunk in re.split(r"^## ", text, flags=re.M)[1:]:
        heading, _, body = chunk.partition("\n")
        paths = set(re.findall(r"params(?:\.\w+)+", heading))
        keys = set(re.findall(r"^\| `([^`]+)` \|", body, flags=re.M))
        sections[heading] = (paths, keys)
    return sections


def _missing(text):
    """'key path: missing keys' for every block whose keys no section under its key path lists."""
    sections = _doc_sections(text)
    problems = []
    for path, cls, word in _blocks():
        wanted = {f.name for f in dataclasses.fields(cls)}
        candidates = [keys for heading, (paths, keys) in sections.items() if path in paths and word in heading]
        if not candidates:
            problems.append(f"{path} ({cls.__name__}): no section with this key path in its heading")
        elif not any(wanted <= keys for keys in candidates):
            best = max(candidates, key=lambda keys: len(wanted & keys))
            problems.append(f"{path} ({cls.__name__}): missing {sorted(wanted - best)}")
    return problems


@pytest.fixture(scope="module")
def config_md():
    with open(os.path.join(ROOT, "docs", "config.md"), encoding="utf-8") as fh:
        return fh.read()


def test_walk_reaches_the_nested_blocks():
    found = {(path, cls.__name__) for path, cls, _ in _blocks()}
    for block in [("params.network.rnn", "RnnConfig"), ("params.network.cnn", "CnnConfig"),
                  ("params.network.cnn", "ResnetCnnConfig"), ("params.network.cnn.convs", "ConvSpec"),
                  ("params.config.central_value_config", "CentralValueConfig"),
                  ("params.network.mlp.initializer", "InitializerConfig"),
                  ("params.network", "SACNetworkConfig"), ("params.config", "DQNConfig")]:
        assert block in found


def test_every_key_of_every_block_in_config_md(config_md):
    problems = _missing(config_md)
    assert not problems, "docs/config.md leaves out:\n" + "\n".join(problems)


def test_a_dropped_section_is_seen(config_md):
    """Dropping the rnn section, or one row of the resnet cnn, must show up as a problem."""
    without_rnn = re.sub(r"^## params\.network\.rnn\b.*?(?=^## )", "", config_md, flags=re.M | re.S)
    assert without_rnn != config_md
    assert any(p.startswith("params.network.rnn (RnnConfig)") for p in _missing(without_rnn))
    heading = "## params.network.cnn (builder resnet_actor_critic)"
    start = config_md.index(heading)
    row = config_md.index("| `conv_depths` |", start)
    without_row = config_md[:row] + config_md[config_md.index("\n", row) + 1:]
    assert any("ResnetCnnConfig): missing ['conv_depths']" in p for p in _missing(without_row))
