"""``model.save("name")``: ``name.zip``, SB3's archive layout with rlchain's own model file inside.

SB3 adds ``.zip`` to a path without one and its guides load ``name.zip`` back, so the SB3 face does the same. The
archive holds what SB3's layout has (``data``, ``policy.pth`` under SB3's parameter names,
``_stable_baselines3_version``, ``system_info.txt``) and rlchain's whole model file as ``rlchain_model.pt`` (SB3
reads only ``.pth`` members and ``data``, so it passes over it). For an MlpPolicy model whose network has SB3's
layout, and with stable-baselines3 installed, the archive is the one SB3 itself writes (SB3's ``load`` reads it);
otherwise ``data`` holds plain values only. rlchain reads ``rlchain_model.pt`` back as data
(:func:`rlchain.sb3.files.load_model`), so the model, its config and its classes' names round-trip exactly.
"""

from __future__ import annotations

import io
import json
import os
import platform
import tempfile
import zipfile
from collections.abc import Callable
from typing import Any

import torch

from rlchain.runs import archive
from rlchain.runs import checkpoint as ckpt
from rlchain.version import __version__

MEMBER = "rlchain_model.pt"


def system_info() -> dict[str, str]:
    """What SB3's ``print_system_info`` lists, for this process."""
    import gymnasium
    import numpy
    return {"OS": platform.platform(), "Python": platform.python_version(), "rlchain": __version__,
            "PyTorch": torch.__version__, "GPU Enabled": str(torch.cuda.is_available()), "Numpy": numpy.__version__,
            "Gymnasium": gymnasium.__version__}


def format_system_info(info: dict[str, str]) -> str:
    return "".join(f"- {key}: {value}\n" for key, value in info.items())


def write_model_zip(path: str, write_own: Callable[[str], Any], write_sb3: Callable[[str], Any] | None,
                    policy_state: dict[str, torch.Tensor], num_timesteps: int) -> str:
    """Write the archive at ``path`` (atomically): ``write_own(file)`` writes rlchain's model file, ``write_sb3``
    (None: not SB3's layout) SB3's own archive; when SB3 cannot write it, the layout's members hold plain data."""
    folder = os.path.dirname(os.path.abspath(path))
    with tempfile.TemporaryDirectory(dir=folder) as tmp:
        own, archive = os.path.join(tmp, "model.pth"), os.path.join(tmp, "archive.zip")
        write_own(own)
        written = False
        if write_sb3 is not None:
            try:
                write_sb3(archive)
                written = True
            except Exception:  # no stable-baselines3, a network its MlpPolicy cannot hold, arguments it refuses
                written = False
        if not written:
            buffer = io.BytesIO()
            torch.save(dict(policy_state), buffer)
            data = {"rlchain": f"a model saved by rlchain {__version__}; its whole state is {MEMBER}",
                    "num_timesteps": int(num_timesteps)}
            with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as z:
                z.writestr("data", json.dumps(data, indent=4))
                z.writestr("policy.pth", buffer.getvalue())
                z.writestr("_stable_baselines3_version", f"rlchain {__version__}")
                z.writestr("system_info.txt", format_system_info(system_info()))
        with zipfile.ZipFile(archive, "a", zipfile.ZIP_DEFLATED) as z:
            z.write(own, MEMBER)
        os.replace(archive, path)
    return path


def has_model(path: str) -> bool:
    """Whether ``path`` is an archive :func:`write_model_zip` wrote (it holds rlchain's model file)."""
    try:
        with zipfile.ZipFile(path) as z:
            return MEMBER in z.namelist()
    except (OSError, zipfile.BadZipFile):
        return False


def read_model(path: str, load: Callable[[str], Any]) -> Any:
    """``load(file)`` of the rlchain model file inside the archive ``path`` (an error names ``path:member``)."""
    folder = os.path.dirname(os.path.abspath(path))
    with tempfile.TemporaryDirectory(dir=folder) as tmp:
        own = os.path.join(tmp, "model.pth")
        try:  # within bounds: a plain file, at most archive.WEIGHTS_LIMIT inflated
            data = archive.read_member(path, MEMBER, archive.WEIGHTS_LIMIT)
        except archive.ArchiveError as exc:
            raise ckpt.CheckpointError(str(exc)) from None
        with open(own, "wb") as f:
            f.write(data)
        try:
            return load(own)
        except ckpt.CheckpointError as exc:
            raise ckpt.CheckpointError(str(exc).replace(own, f"{path}:{MEMBER}")) from None


def saved_system_info(path: str) -> str | None:
    """The ``system_info.txt`` an archive holds, or None."""
    try:
        with zipfile.ZipFile(path) as z:
            if "system_info.txt" not in z.namelist():
                return None
        return archive.read_member(path, "system_info.txt", 1 << 20).decode("utf-8", "replace")
    except (OSError, zipfile.BadZipFile):
        return None
    except archive.ArchiveError as exc:
        return f"(not shown: {exc})\n"
