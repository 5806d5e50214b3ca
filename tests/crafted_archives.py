"""Crafted zip archives for the tests of readers of files from others: a member that inflates to gigabytes from a
file of a few megabytes (a zip bomb, built without ever holding or compressing the gigabytes), and a member whose
declared size is a lie. Written by hand (local headers, central directory, ZIP64 sizes) so that nothing here
needs memory or time in proportion to what the archive claims.
"""

import struct
import zlib

ZEROS_CHUNK = 64 * 2**20
"""Each repeated deflate block inflates to this many zero bytes."""


def _zero_blocks() -> tuple[bytes, bytes]:
    """(deflate blocks that inflate to ZEROS_CHUNK zeros, self-contained after a full flush; the final block)."""
    comp = zlib.compressobj(9, zlib.DEFLATED, -15)
    block = comp.compress(bytes(ZEROS_CHUNK)) + comp.flush(zlib.Z_FULL_FLUSH)
    return block, b"\x03\x00"  # an empty final block with fixed Huffman codes


_BLOCKS: list[tuple[bytes, bytes]] = []


def zeros_deflated(size: int) -> bytes:
    """A raw deflate stream that inflates to ``size`` zero bytes (a multiple of ZEROS_CHUNK, rounded up)."""
    if not _BLOCKS:
        _BLOCKS.append(_zero_blocks())
    block, final = _BLOCKS[0]
    return block * -(-size // ZEROS_CHUNK) + final


def write_zip(path, members) -> str:
    """Write ``members`` — ``(name, payload, method, declared_size, crc)`` with ``method`` 0 (stored) or 8
    (deflate, ``payload`` already compressed) — as a zip with ZIP64 sizes; returns ``path``."""
    out, central = bytearray(), bytearray()
    for name, payload, method, declared, crc in members:
        raw = name.encode()
        extra = struct.pack("<HHQQ", 1, 16, declared, len(payload))
        offset = len(out)
        out += struct.pack("<IHHHHHIIIHH", 0x04034B50, 45, 0, method, 0, 0x21, crc, 0xFFFFFFFF, 0xFFFFFFFF,
                           len(raw), len(extra)) + raw + extra + payload
        cextra = struct.pack("<HHQQQ", 1, 24, declared, len(payload), offset)
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 45, 45, 0, method, 0, 0x21, crc, 0xFFFFFFFF,
                               0xFFFFFFFF, len(raw), len(cextra), 0, 0, 0, 0, 0xFFFFFFFF) + raw + cextra
    start = len(out)
    out += central
    out += struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(members), len(members), len(central), start, 0)
    with open(path, "wb") as fh:
        fh.write(out)
    return str(path)


def stored(name: str, data: bytes) -> tuple:
    """A member stored as it is."""
    return name, data, 0, len(data), zlib.crc32(data)


def bomb(name: str, size: int, declared: int | None = None) -> tuple:
    """A member of ``size`` zeros (deflated: about size / 1000 bytes in the file), declaring ``declared``
    (default: its true size; its CRC is left 0, which a reader that refuses first never checks)."""
    return name, zeros_deflated(size), 8, size if declared is None else declared, 0


def members_of(path) -> list[tuple]:
    """The members of an ordinary zip as ``stored`` entries, to rebuild it with one of them replaced."""
    import zipfile

    with zipfile.ZipFile(path) as archive:
        return [stored(info.filename, archive.read(info.filename)) for info in archive.infolist()]
