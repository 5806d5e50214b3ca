"""Members of a zip archive from elsewhere (a Stable-Baselines3 model), read with bounds: a member is read only
when it is a plain file whose declared size is under a stated limit, in chunks, and no further than it declared,
so a member that inflates to gigabytes from a few megabytes (a zip bomb) is refused before it is inflated.
Every refusal is one :class:`~rlchain.runs.checkpoint.CheckpointError`-style line naming the archive and member.
"""

from __future__ import annotations

import io
import stat
import zipfile
import zlib

CHUNK = 1 << 20
WEIGHTS_LIMIT = 2 << 30
"""The most bytes a weights member (``policy.pth``, ``pytorch_variables.pth``) may inflate to: 2 GiB, far above
any real model (SB3's MlpPolicy files are kilobytes, image policies tens of megabytes)."""
DATA_LIMIT = 256 << 20
"""The most bytes SB3's ``data`` JSON may inflate to: 256 MiB (SB3 writes kilobytes to a few megabytes)."""


class ArchiveError(ValueError):
    """A member that cannot be read within bounds; its message is one line naming the archive and member."""


def size_text(n: int) -> str:
    """``n`` bytes in words (``2.0 GiB``)."""
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= scale:
            return f"{n / scale:.1f} {unit}"
    return f"{n} bytes"


def is_symlink(info: zipfile.ZipInfo) -> bool:
    """Whether the member is a symbolic link (a Unix mode in its external attributes)."""
    return info.create_system == 3 and stat.S_ISLNK(info.external_attr >> 16)


def read_member(path: str, member: str, limit: int) -> bytes:
    """The bytes of ``member`` in the zip ``path``, at most ``limit`` of them: ArchiveError (one line) for a missing
    member, a symbolic link, a declared size over ``limit``, data beyond the declared size or a damaged member."""
    try:
        with zipfile.ZipFile(path) as archive:
            try:
                info = archive.getinfo(member)
            except KeyError:
                raise ArchiveError(f"{path}: no '{member}' in the archive") from None
            if is_symlink(info):
                raise ArchiveError(f"{path}: '{member}' is a symbolic link inside the archive, not a file; "
                                   f"rlchain reads an archive's members as files only")
            if info.file_size > limit:
                raise ArchiveError(f"{path}: '{member}' declares {size_text(info.file_size)} uncompressed; rlchain "
                                   f"reads at most {size_text(limit)} of it (far above any real model)")
            out = bytearray()
            with archive.open(info) as fh:  # zipfile stops at the declared size and checks the CRC there
                while chunk := fh.read(min(CHUNK, limit + 1 - len(out))):
                    out += chunk
                    if len(out) > limit:
                        raise ArchiveError(f"{path}: '{member}' inflates past {size_text(limit)}")
            return bytes(out)
    except ArchiveError:
        raise
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error, NotImplementedError, RuntimeError) as exc:
        raise ArchiveError(f"{path}: '{member}' cannot be read ({type(exc).__name__}: "
                           f"{' '.join(str(exc).split())[:120]})") from None


def check_torch_records(data: bytes, path: str, member: str, limit: int) -> None:
    """A torch-saved member is itself a zip; its records' declared sizes must add up to no more than ``limit``
    (torch inflates each record whole), and none may be a symbolic link."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as inner:
            infos = inner.infolist()
    except zipfile.BadZipFile:
        return  # not a zip (a legacy torch pickle): torch's reader says what it is
    total = sum(info.file_size for info in infos)
    if total > limit:
        raise ArchiveError(f"{path}: '{member}' declares {size_text(total)} of tensors; rlchain reads at most "
                           f"{size_text(limit)} (far above any real model)")
    if any(is_symlink(info) for info in infos):
        raise ArchiveError(f"{path}: '{member}' holds a symbolic link, not torch records")
