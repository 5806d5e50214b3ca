"""Checkpoints: atomic writes with tensor checksums, loading as data (never as code unless trusted),
exact resume state, and clear errors for bad files."""

from __future__ import annotations

import io
import os
import pickle
import random
import re
import threading
import zipfile
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

import numpy as np
import torch
from gymnasium.wrappers.utils import RunningMeanStd

try:
    from numpy._core import multiarray as _multiarray
except ImportError:  # numpy 1.x
    from numpy.core import multiarray as _multiarray

from rlchain.envs.backends.pettingzoo_env import AgentObs
from rlchain.log import get_logger
from rlchain.runs import archive, digest, rl_games_checkpoint
from rlchain.runs.atomic import write_atomic

log = get_logger(__name__)

FORMAT = "rlchain-checkpoint-1"
RLCHAIN_MODEL = "rlchain_model"
"""Where a checkpoint written under rl_games' API keeps rlchain's model state (``model`` holds rl_games' layout)."""
NORMS_DROPPED = "mlp_norms_dropped"
"""A checkpoint key (and the attribute :func:`load_model_state` sets on the model it loads): the model was built
without its config's MLP normalization layers, continuing an rl_games 1.6.5 run (1.6.5 never builds them); a
checkpoint that says so is loaded the same way again."""
TRUST_HINT = ("unpickling it would run code from the file; if you trust the file, load it with "
              "--trust-checkpoint (params.config.trust_checkpoint: true)")

_trusted: ContextVar[bool] = ContextVar("rlchain_trust_checkpoints", default=False)


class CheckpointError(RuntimeError):
    """A checkpoint that cannot be read or does not fit the model."""


@contextmanager
def trusting(trust: bool = True) -> Iterator[None]:
    """Within the block, checkpoints load with full pickle (any object, any code it names): for files the
    user trusts, e.g. one written by an older tool that stored its own classes. ``trust=False`` keeps the
    setting of an enclosing block."""
    token = _trusted.set(bool(trust) or _trusted.get())
    try:
        yield
    finally:
        _trusted.reset(token)


def is_trusted() -> bool:
    """Whether checkpoints load with full pickle here (inside :func:`trusting`)."""
    return _trusted.get()


def save_atomic(state: dict[str, Any], path: str) -> None:
    """Write ``state`` with a checksum of every tensor to ``path`` through a temp file + rename: a crash
    never leaves half a file, and a later corruption is caught on load."""
    state = {**_encode(state), digest.KEY: digest.digest(state)}
    write_atomic(path, lambda fh: torch.save(state, fh), suffix=".pth")


def _data_types() -> list[Any]:
    """What rlchain writes besides tensors and plain containers (torch's own allow-list): numpy arrays,
    scalars and dtypes (RNG states, env states, replay counters) and gymnasium's running mean
    (a gymnasium env's wrapper state). Loading builds these from the file's data and runs nothing else."""
    types: list[Any] = [np.ndarray, np.dtype, bytes]
    for module in ("numpy._core.multiarray", "numpy.core.multiarray"):  # numpy 2's name, numpy 1's
        types += [(_multiarray._reconstruct, f"{module}._reconstruct"), (_multiarray.scalar, f"{module}.scalar")]
    dtypes = getattr(np, "dtypes", None)  # the dtype classes (numpy >= 1.25)
    types += [getattr(dtypes, name) for name in dir(dtypes) if name.endswith("DType")] if dtypes else []
    types += [RunningMeanStd, AgentObs]  # a gymnasium wrapper's statistics; multi-agent observations in progress
    return types


_allowed = threading.Lock()
_allowed_done: list[bool] = []


def _allow_data_types() -> None:
    """Add :func:`_data_types` to torch's ``weights_only`` allow-list, once per process. Process-wide rather
    than a ``safe_globals`` block, which edits the same global list and would race between threads (a Tune
    stepper's training thread and its caller); the types are data, so other ``weights_only`` loads of the
    process may read them too."""
    with _allowed:
        if not _allowed_done:
            torch.serialization.add_safe_globals(_data_types())
            _allowed_done.append(True)


def _refused_type(path: str, exc: Exception) -> str:
    """The first global a file names that is not data (from torch's refusal, else from a scan of the file)."""
    match = re.search(r"GLOBAL ([\w.]+)", str(exc))
    if match:
        return match.group(1)
    try:
        allowed = {t[1] if isinstance(t, tuple) else f"{t.__module__}.{t.__name__}" for t in _data_types()}
        unsafe = [g for g in torch.serialization.get_unsafe_globals_in_checkpoint(path) if g not in allowed]
        return unsafe[0] if unsafe else ""
    except Exception:  # not a zip checkpoint: the caller reports it as unreadable
        return ""


def _reason(path: str, exc: Exception) -> str:
    """Why torch could not read ``path``, in a few words: never torch's advice to load with
    ``weights_only=False`` (running the file's code is the user's call, made with --trust-checkpoint)."""
    with open(path, "rb") as fh:
        head = fh.read(2)
    if not zipfile.is_zipfile(path):  # torch.save's format since torch 1.6; before: a protocol-2 pickle
        if head[:1] != b"\x80":
            return "neither a zip archive (torch.save) nor a pickle: not a checkpoint, or the start of it is lost"
        if head != b"\x80\x02":
            return (f"a plain Python pickle (protocol {head[1]}), not a file torch.save wrote; rlchain reads "
                    f"checkpoints as data only")
    text = str(exc)
    inner = re.search(r"WeightsUnpickler error:(.*?)(Check the documentation|$)", text, re.S)
    if inner or "weights_only" in text:
        text = inner.group(1) if inner else "torch's data-only reader refused it"
    text = " ".join(text.split())[:200]
    return f"{type(exc).__name__}: {text}" if text else f"{type(exc).__name__}, no further detail"


def load(path: str, map_location: str | torch.device = "cpu", trusted: bool | None = None) -> dict[str, Any]:
    """Read a checkpoint written by rlchain as data (see :func:`read`); any other file is a one-line
    CheckpointError."""
    state = own_state(read(path, map_location, trusted))
    if not isinstance(state, dict) or state.get("format") != FORMAT:
        if rl_games_checkpoint.is_rl_games_checkpoint(state):  # rl_games 1.6.5 / 2.0: read as rlchain's
            try:
                return {**rl_games_checkpoint.from_rl_games(state), "format": FORMAT}
            except ValueError as exc:
                raise CheckpointError(f"{path}: an rl_games checkpoint rlchain cannot read: {exc}") from None
        raise CheckpointError(f"{path}: not an rlchain checkpoint (no '{FORMAT}' marker)")
    return state


def own_state(state: Any) -> Any:
    """An rlchain checkpoint written under rl_games' API (rl_games' ``model`` beside rlchain's ``rlchain_model``)
    with rlchain's model state back under ``model``; any other object as it is."""
    if isinstance(state, dict) and state.get("format") == FORMAT and RLCHAIN_MODEL in state:
        state = {k: v for k, v in state.items() if k != RLCHAIN_MODEL} | {"model": state[RLCHAIN_MODEL]}
    return state


def read(path: str, map_location: str | torch.device = "cpu", trusted: bool | None = None) -> Any:
    """Read any torch-saved file as data: tensors, numpy arrays and plain containers only (``weights_only``),
    e.g. a checkpoint of another library to import. A file naming any other object (a class, a function: code
    that unpickling would run) is refused with one line naming the file and the type, unless it is trusted
    (``trusted=True`` or inside :func:`trusting`). A tensor whose checksum differs from the one rlchain saved
    with it is an error naming it."""
    if not os.path.isfile(path):
        raise CheckpointError(f"{path}: checkpoint not found")
    if os.path.getsize(path) == 0:
        raise CheckpointError(f"{path}: the file is empty (0 bytes), not a checkpoint: a write that never finished? "
                              f"use another checkpoint")
    trust = is_trusted() if trusted is None else trusted
    if not trust:
        _check_inflation(path)
    try:
        if trust:
            state = torch.load(path, map_location=map_location, weights_only=False)
        else:
            _allow_data_types()
            state = torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as exc:
        name = None if trust else _refused_type(path, exc)
        if name:
            raise CheckpointError(f"{path}: refused: it names the type '{name}', which is not checkpoint data "
                                  f"(tensors, arrays, numbers, strings, containers); {TRUST_HINT}") from None
        raise CheckpointError(f"{path}: not a readable checkpoint ({_reason(path, exc)})") from None
    except Exception as exc:  # torch raises many types for a corrupt file
        if is_sb3_layout(path):
            raise CheckpointError(f"{path}: a Stable-Baselines3 model archive (data, policy.pth), not a checkpoint "
                                  f"rlchain writes: load it with rlchain.PPO.load(path) (or SAC / DQN), which "
                                  f"reads it as data") from None
        raise CheckpointError(f"{path}: not a readable checkpoint ({_reason(path, exc)})") from None
    if not isinstance(state, dict):
        return state
    bad = digest.first_mismatch(state)
    if bad is not None:
        raise CheckpointError(f"{path}: tensor '{bad}' does not match the checksum saved with it: the file "
                              f"is corrupted (disk or copy); use another checkpoint")
    state.pop(digest.KEY, None)
    return _decode(state)


INFLATION_SLACK = 256 << 20
"""How many bytes a torch file's records may declare beyond the file's own size. torch stores its records
uncompressed, so a real checkpoint's records add up to about its size; a file whose records inflate far past it
(a crafted zip bomb) is refused before torch inflates each record whole."""


def _check_inflation(path: str) -> None:
    """One line for a torch (zip) file whose records declare far more bytes than the file holds."""
    try:
        with zipfile.ZipFile(path) as z:
            declared = sum(info.file_size for info in z.infolist())
    except (zipfile.BadZipFile, OSError, ValueError):
        return  # not a zip (a legacy torch pickle, junk): torch's reader says what it is
    if declared > os.path.getsize(path) + INFLATION_SLACK:
        raise CheckpointError(f"{path}: its records declare {archive.size_text(declared)} uncompressed in a "
                              f"{archive.size_text(os.path.getsize(path))} file; torch writes records uncompressed, "
                              f"so this is not a checkpoint torch wrote (refused before inflating)")


def is_sb3_layout(path: str) -> bool:
    """Whether ``path`` is a zip with Stable-Baselines3's ``data`` and ``policy.pth`` (its model archive)."""
    try:
        with zipfile.ZipFile(path) as archive:
            return {"data", "policy.pth"} <= set(archive.namelist())
    except (OSError, zipfile.BadZipFile):
        return False


def read_zip_member(path: str, member: str, map_location: str | torch.device = "cpu") -> Any:
    """One torch-saved file inside a zip archive (a Stable-Baselines3 model's ``policy.pth``), read as data
    (``weights_only``; never trusted: such archives come from elsewhere) and within bounds
    (:mod:`rlchain.runs.archive`: a plain file, at most :data:`~rlchain.runs.archive.WEIGHTS_LIMIT` inflated). A
    missing, oversized, linked or unreadable member, or one naming code, is a one-line CheckpointError."""
    try:
        raw = archive.read_member(path, member, archive.WEIGHTS_LIMIT)
        archive.check_torch_records(raw, path, member, archive.WEIGHTS_LIMIT)
    except archive.ArchiveError as exc:
        raise CheckpointError(str(exc)) from None
    _allow_data_types()
    try:
        return torch.load(io.BytesIO(raw), map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as exc:
        match = re.search(r"GLOBAL ([\w.]+)", str(exc))
        raise CheckpointError(f"{path}: '{member}' refused: it names "
                              f"{repr(match.group(1)) if match else 'a type'}, which is not data") from None
    except Exception as exc:
        raise CheckpointError(f"{path}: '{member}' is not a readable torch file ({type(exc).__name__}: "
                              f"{' '.join(str(exc).split())[:160]})") from None


_DEQUE = "__rlchain_deque__"


def _encode(value: Any) -> Any:
    """``value`` with every deque (a frame-stack queue in a gymnasium env's state) as a tagged dict, which
    ``weights_only`` can read; the object itself when it holds none."""
    if isinstance(value, deque):
        return {_DEQUE: [_encode(v) for v in value], "maxlen": value.maxlen}
    return _rebuilt(value, _encode)


def _decode(value: Any) -> Any:
    """:func:`_encode` undone."""
    if type(value) is dict and _DEQUE in value:
        return deque((_decode(v) for v in value[_DEQUE]), maxlen=value["maxlen"])
    return _rebuilt(value, _decode)


def _rebuilt(value: Any, fn: Any) -> Any:
    """A plain dict, list or tuple with ``fn`` applied to each item, rebuilt only when an item changed (so an
    OrderedDict state_dict, never rebuilt, keeps its metadata); anything else as it is."""
    if type(value) is dict:
        items = {k: fn(v) for k, v in value.items()}
        return items if any(items[k] is not value[k] for k in value) else value
    if type(value) in (list, tuple):
        items = [fn(v) for v in value]
        return type(value)(items) if any(a is not b for a, b in zip(items, value)) else value
    return value


def load_model_state(model: torch.nn.Module, state: dict[str, Any], path: str) -> None:
    """Load weights, naming the first parameter whose name or shape does not match. ``state['keep_built']``:
    tensors the checkpoint lacks on purpose (an imported file that never held them) keep the built model's."""
    own = model.state_dict()
    saved = state["model"]
    keep = set(state.get("keep_built") or ())
    missing = [k for k in own if k not in saved and k not in keep]
    unexpected = [k for k in saved if k not in own]
    continues_165 = state.get("origin") == "rl_games" or bool(state.get(NORMS_DROPPED))
    mismatch = missing or unexpected or any(tuple(v.shape) != tuple(own[k].shape) for k, v in saved.items() if k in own)
    if mismatch and continues_165 and not mlp_norms(saved) and drop_unbuilt_norms(model):
        which = ("its checkpoint has" if state.get("origin") == "rl_games"
                 else "this run continues one, whose files have")
        log.warning(f"{path}: rl_games 1.6.5 builds no MLP normalization layers whatever network.normalization "
                    f"says; {which} none, so the model is built without them")
        setattr(model, NORMS_DROPPED, True)  # the checkpoints this model is saved to say so
        own = model.state_dict()
        missing = [k for k in own if k not in saved and k not in keep]
        unexpected = [k for k in saved if k not in own]
    if missing or unexpected:
        detail = f"missing {missing[:3]}" if missing else f"unexpected {unexpected[:3]}"
        hint = "was it trained with another config?"
        if state.get("origin") == "rl_games":
            hint = _rl_games_norm_hint(saved, own) or hint
        raise CheckpointError(f"{path}: checkpoint does not match this model's network ({detail}); {hint}")
    for key, value in saved.items():
        if tuple(value.shape) != tuple(own[key].shape):
            changed = _changed_env_inputs(state, tuple(value.shape), tuple(own[key].shape))
            if changed is not None:
                raise CheckpointError(f"{path}: {changed}")
            raise CheckpointError(f"{path}: parameter '{key}' has shape {tuple(value.shape)} in the "
                                  f"checkpoint but {tuple(own[key].shape)} in this model")
    model.load_state_dict(saved, strict=not keep)


CHANGED_ENV_INPUTS = {
    "CartPoleMaskedVelocity-v1": (2, 4, "CartPole's four entries with both velocities zeroed, as rl_games masks "
                                 "them (it was: cart position and pole angle only); retrain on it, or play this "
                                 "file on an env of your own that keeps entries 0 and 2"),
}
"""Example envs whose observation changed: env name -> (inputs before, inputs now, what the env is now and what
to do). A checkpoint of the old shape is refused with that line: it is not widened on load (no shims)."""


def _changed_env_inputs(state: dict[str, Any], saved: tuple[int, ...], own: tuple[int, ...]) -> str | None:
    """The reason a tensor of shape ``saved`` does not fit the model (``own``) when the checkpoint was trained
    on an example env whose observation has changed since (:data:`CHANGED_ENV_INPUTS`), else None."""
    config = ((state.get("config") or {}).get("params") or {}).get("config") or {}
    env_name = config.get("env_name") if isinstance(config, dict) else None
    if env_name not in CHANGED_ENV_INPUTS or not saved or not own:
        return None
    before, now, what = CHANGED_ENV_INPUTS[env_name]
    if (saved[-1], own[-1]) != (before, now):
        return None
    return f"trained on {env_name} when it observed {before} inputs; the env now observes {now}: {what}"


MLP_WEIGHT = re.compile(r"(?:^|\.)(?:actor_mlp|critic_mlp|mlp|trunk|Q[12])\.(\d+)\.weight$")
"""A weight inside one of the MLP Sequentials (rl_games' layout: linear, activation[, norm], linear, ...)."""


def mlp_norms(weights: dict[str, Any]) -> list[str]:
    """The keys of normalization layers' weights (one-dimensional) inside the MLPs of a state dict."""
    return [key for key, value in weights.items() if MLP_WEIGHT.search(key) and len(value.shape) == 1]


def drop_unbuilt_norms(model: torch.nn.Module) -> bool:
    """Rebuild every Sequential of ``model`` without its LayerNorm / BatchNorm1d layers, as rl_games 1.6.5 builds
    the network whatever ``network.normalization`` says (an rl_games 1.6.5 file whose config names it); returns
    whether there were any."""
    norms = (torch.nn.LayerNorm, torch.nn.BatchNorm1d)
    dropped = False
    for module in list(model.modules()):
        if isinstance(module, torch.nn.Sequential) and any(isinstance(m, norms) for m in module):
            kept = [m for m in module if not isinstance(m, norms)]
            for name in list(module._modules):
                del module._modules[name]
            for layer in kept:
                module.append(layer)
            dropped = True
    return dropped


def _rl_games_norm_hint(saved: dict[str, Any], own: dict[str, Any]) -> str:
    """What to change when an rl_games checkpoint's MLP normalization layers differ from the model's."""
    if mlp_norms(saved):
        return ("this rl_games checkpoint normalizes after the activation (network.normalization in rl_games "
                "2.0): set network.mlp.norm_after_activation: True")
    if mlp_norms(own):
        return ("rl_games 1.6.5 builds no MLP normalization layers whatever network.normalization says: drop "
                "that key to play or resume its checkpoints")
    return ""


def rng_state() -> dict[str, Any]:
    """All random generator states, so a resumed run draws the same numbers."""
    state = {"python": random.getstate(), "numpy": np.random.get_state(), "torch": torch.get_rng_state()}
    if torch.cuda.is_available():
        state["cuda"] = torch.cuda.get_rng_state_all()
    return state


def set_rng_state(state: dict[str, Any]) -> None:
    random.setstate(state["python"])
    np.random.set_state(state["numpy"])
    torch.set_rng_state(state["torch"].cpu())
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all([s.cpu() for s in state["cuda"]])


def seed_everything(seed: int) -> None:
    """Seed python, numpy and torch (CPU and CUDA)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
