"""What ``rlchain compare`` reads from run folders that may come from anyone, read within bounds: only regular
files (a FIFO or a device is refused by ``stat`` before it is opened, so nothing waits on a pipe), config.yaml as
UTF-8 text without YAML aliases, TensorBoard event files record by record with each record's length checked
against the file (:func:`scalar_events`), and folders walked without following a symbolic link back into a
folder already seen.
"""

from __future__ import annotations

import os
import stat
import struct
from collections.abc import Iterator
from typing import Any

import yaml

CONFIG_LIMIT = 16 << 20
"""The largest config.yaml read (a run's config is kilobytes)."""
RECORD_LIMIT = 256 << 20
"""The largest TensorBoard record read (a scalar's record is tens of bytes, an image's a few megabytes)."""
KINDS = {stat.S_IFIFO: "a FIFO", stat.S_IFCHR: "a character device", stat.S_IFBLK: "a block device",
         stat.S_IFSOCK: "a socket", stat.S_IFDIR: "a folder"}


class _NoAliases(yaml.SafeLoader):
    """Safe YAML that refuses aliases (``*name``): rlchain writes none, and nested ones expand beyond memory and
    time when the config is walked (rlchain.config.text's loader does the same for configs; compare imports no
    other rlchain module)."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise CompareError(f"line {event.start_mark.line + 1}: YAML alias *{event.anchor} is not allowed")
        return super().compose_node(parent, index)


class CompareError(ValueError):
    """Bad input to ``rlchain compare``: no run matched, a folder without events, an unknown tag, a refused file
    ... (one line)."""


def open_regular(path: str) -> Any:
    """``path`` opened for reading in binary, refused (CompareError) unless it is a regular file: checked with
    ``stat`` before opening (a FIFO is never opened) and again on the open file (it cannot be swapped between)."""
    mode = os.stat(path).st_mode
    if not stat.S_ISREG(mode):
        raise CompareError(f"{path}: {KINDS.get(stat.S_IFMT(mode), 'not a regular file')}, not a file: refused")
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise CompareError(f"{path}: not a regular file: refused")
    return os.fdopen(fd, "rb")


def read_config(path: str) -> Any:
    """The YAML of ``path`` (a run's config.yaml), None when there is none or it is not YAML; CompareError (one
    line) for a special file, a file over :data:`CONFIG_LIMIT`, text that is not UTF-8 or a YAML alias."""
    try:
        fh = open_regular(path)
    except FileNotFoundError:
        return None
    with fh:
        data = fh.read(CONFIG_LIMIT + 1)
    if len(data) > CONFIG_LIMIT:
        raise CompareError(f"{path}: larger than {CONFIG_LIMIT >> 20} MiB: not a run's config")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise CompareError(f"{path}: not UTF-8 text (byte {exc.start}): not a config rlchain wrote") from None
    try:
        return yaml.load(text, Loader=_NoAliases)  # noqa: S506 (a safe loader that also refuses aliases)
    except CompareError as exc:
        raise CompareError(f"{path}: {exc}") from None
    except (yaml.YAMLError, RecursionError):
        return None


def walk_files(root: str) -> Iterator[str]:
    """Every file name under ``root`` (sorted per folder), following symbolic links to folders but never into a
    folder already walked (``a -> .`` ends there)."""
    seen: set[str] = set()
    for folder, dirs, files in os.walk(root, followlinks=True):
        real = os.path.realpath(folder)
        if real in seen:
            dirs[:] = []
            continue
        seen.add(real)
        dirs[:] = sorted(d for d in dirs if os.path.realpath(os.path.join(folder, d)) not in seen)
        for name in sorted(files):
            yield os.path.join(folder, name)


def records(path: str) -> Iterator[tuple[int, bytes]]:
    """``(offset, data)`` of every TFRecord in the event file ``path``: a length (8 bytes), its CRC (4), the data,
    its CRC (4). A length beyond the rest of the file or :data:`RECORD_LIMIT`, or a length whose CRC does not match,
    is a CompareError (one line) before anything of that length is read; a file that ends inside a header ends."""
    from tensorboard.compat.tensorflow_stub.pywrap_tensorflow import masked_crc32c  # optional: tensorboard

    with open_regular(path) as fh:
        size = os.fstat(fh.fileno()).st_size
        offset = 0
        while offset + 12 <= size:
            header = fh.read(12)
            if len(header) < 12:
                return
            length, crc = struct.unpack("<QI", header)
            if masked_crc32c(header[:8]) != crc:
                raise CompareError(f"{path}: the record at byte {offset} has a damaged length (its CRC does not "
                                   f"match): not a TensorBoard event file, or a damaged one")
            left = size - offset - 12  # after the header: the data and its CRC (4 bytes)
            if length + 4 > left or length > RECORD_LIMIT:
                raise CompareError(f"{path}: the record at byte {offset} claims {length} bytes, the file has {left} "
                                   f"after its header (at most {RECORD_LIMIT >> 20} MiB read): a "
                                   f"damaged event file, or one still being written (try again when it is done)")
            data = fh.read(length)
            fh.read(4)
            yield offset, data
            offset += 16 + length


def scalar_events(path: str, tags: Any = None) -> tuple[float | None, list[tuple[str, float, float, float]]]:
    """(the first event's wall time, ``(tag, wall time, step, value)`` of every scalar, or of ``tags``) of the
    event file ``path``; (None, []) for an empty file."""
    from google.protobuf.message import DecodeError  # optional: tensorboard (and its protobuf)
    from tensorboard.compat.proto import event_pb2
    from tensorboard.util import tensor_util

    first, rows = None, []
    for offset, data in records(path):
        try:
            event = event_pb2.Event.FromString(data)
        except DecodeError:
            raise CompareError(f"{path}: the record at byte {offset} is not a TensorBoard event") from None
        if first is None:
            first = event.wall_time
        for value in event.summary.value:
            if tags is not None and value.tag not in tags:
                continue
            if value.HasField("simple_value"):
                rows.append((value.tag, event.wall_time, float(event.step), float(value.simple_value)))
            elif value.HasField("tensor") and value.metadata.plugin_data.plugin_name == "scalars" \
                    and not value.tensor.tensor_shape.dim:  # a scalar tensor only: a shape is never expanded
                try:
                    number = float(tensor_util.make_ndarray(value.tensor).reshape(()))
                except (ValueError, TypeError):
                    raise CompareError(f"{path}: the record at byte {offset} holds a malformed scalar "
                                       f"'{value.tag[:60]}'") from None
                rows.append((value.tag, event.wall_time, float(event.step), number))
    return first, rows
