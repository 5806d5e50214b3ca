"""rlchain/faces.py: the import alias and the script launcher both compatibility faces use, on a made-up peer."""

import importlib
import sys
import types

import pytest

import rlchain.compare.stats
from rlchain.faces import ModuleAlias, run_script


class PeerAlias(ModuleAlias):
    """``peer.stats`` -> ``rlchain.compare.stats``; ``peer.refused`` is refused before any import."""

    ALIAS = "fakepeer.sub"
    TARGET = "rlchain.compare"

    def refuse(self, fullname):
        if fullname == "fakepeer.sub.refused":
            raise ImportError("fakepeer.sub.refused: use stats instead", name=fullname)


@pytest.fixture
def parent():
    """The peer's real parent package (``ray`` for ``ray.rllib``)."""
    sys.modules["fakepeer"] = types.ModuleType("fakepeer")
    sys.modules["fakepeer"].__path__ = []  # a package
    yield sys.modules["fakepeer"]
    PeerAlias.uninstall()
    del sys.modules["fakepeer"]


def test_alias_answers_with_the_faces_module_and_uninstalls(parent):
    finder = PeerAlias.install()
    assert PeerAlias.install() is finder and sys.meta_path[0] is finder  # idempotent, first
    assert importlib.import_module("fakepeer.sub.stats") is rlchain.compare.stats
    with pytest.raises(ImportError, match="use stats instead"):
        importlib.import_module("fakepeer.sub.refused")
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module("fakepeer.sub.nothing_here")
    assert parent.sub is rlchain.compare  # the import system set it on the parent package
    PeerAlias.uninstall()
    assert finder not in sys.meta_path and not hasattr(parent, "sub")
    assert not any(name.startswith("fakepeer.sub") for name in sys.modules)
    assert rlchain.compare.stats.__spec__.name == "rlchain.compare.stats"  # the face's module keeps its own spec
    assert PeerAlias.target_name("fakepeer.sub.x") == "rlchain.compare.x" and PeerAlias.target_name("fakepeer") is None


def test_launcher_runs_the_script_with_the_alias_and_explains_in_one_line(parent, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(sys, "argv", list(sys.argv))
    monkeypatch.setattr(sys, "path", list(sys.path))
    script = tmp_path / "script.py"
    script.write_text("import sys\nimport fakepeer.sub.stats\nif sys.argv[1:] == ['boom']:\n"
                      "    raise ValueError('bad value')\n")
    assert run_script([str(script), "ok"], "rlchain.peer", "Peer", PeerAlias) == 0
    assert "stands in for Peer" in capsys.readouterr().out and sys.argv == [str(script), "ok"]
    explain = lambda exc: f"ValueError: {exc}" if isinstance(exc, ValueError) else None  # noqa: E731
    assert run_script([str(script), "boom"], "rlchain.peer", "Peer", PeerAlias, explain) == 1
    assert capsys.readouterr().err == f"{script}: ValueError: bad value\n"
    with pytest.raises(ValueError):  # not explained: through, as under plain python
        run_script([str(script), "boom"], "rlchain.peer", "Peer", PeerAlias)
    assert run_script([str(tmp_path / "missing.py")], "rlchain.peer", "Peer", PeerAlias) == 2
    assert "usage: python -m rlchain.peer SCRIPT" in capsys.readouterr().err
