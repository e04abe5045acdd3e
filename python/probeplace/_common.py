"""What the three readers share: the error class, the provenance, the hashes."""

from __future__ import annotations

import os
import stat
import zlib
from dataclasses import dataclass


class ProbeplaceError(ValueError):
    """A file probeplace's own reader would refuse, or that cannot be read.

    The message is one line, ``PATH: reason``, with the reason probeplace
    itself gives for the same file (``truncated: …``, ``corrupted: …``).
    """


def fnv1a64(data: bytes) -> int:
    """64-bit FNV-1a of ``data`` (src/provenance.rs): the tool hash of the
    binary files' provenance."""
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def crc32(data: bytes) -> int:
    """CRC-32 (IEEE 802.3, as zlib's): the checksum ending both binary files."""
    return zlib.crc32(data) & 0xFFFFFFFF


@dataclass(frozen=True)
class Provenance:
    """The four facts that tie a run's files together (docs/formats.md,
    "Provenance"): the 32 bytes of ``svo.bin`` and ``lightfield.bin``, or
    the ``provenance`` object of the JSON files reduced to the same."""

    config_hash: int
    scene_hash: int
    seed: int
    tool_hash: int

    @classmethod
    def from_bytes(cls, raw: bytes) -> "Provenance":
        """From the 32 header bytes (four little-endian u64)."""
        words = [int.from_bytes(raw[8 * i : 8 * i + 8], "little") for i in range(4)]
        return cls(*words)

    @classmethod
    def from_json(cls, value: object) -> "Provenance | None":
        """From a JSON ``provenance`` object, reduced to bytes as probeplace
        does (``Provenance::to_bytes``: a hash that is not hex counts as
        0); ``None`` when it is not a whole provenance object (probeplace
        then takes it for another run's)."""
        if not isinstance(value, dict):
            return None
        tool, seed, overrides = value.get("tool"), value.get("seed"), value.get("overrides")
        texts = [value.get(k) for k in ("tool", "config_hash", "scene_hash",
                                        "config_given", "cwd", "config_text")]
        if (not all(isinstance(t, str) for t in texts) or not _is_u64(seed)
                or not isinstance(overrides, dict)
                or not isinstance(overrides.get("no_refine"), bool)):
            return None
        return cls(_hex(value["config_hash"]), _hex(value["scene_hash"]), seed,
                   fnv1a64(tool.encode()))

    def __repr__(self) -> str:
        """The hashes in hex, as the JSON files write them."""
        return (f"Provenance(config_hash={self.config_hash:016x}, "
                f"scene_hash={self.scene_hash:016x}, seed={self.seed}, "
                f"tool_hash={self.tool_hash:016x})")

    def to_bytes(self) -> bytes:
        """The 32 bytes the binary files carry."""
        return b"".join(
            w.to_bytes(8, "little")
            for w in (self.config_hash, self.scene_hash, self.seed, self.tool_hash)
        )


def _is_u64(v: object) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 1 << 64


def _hex(text: str) -> int:
    """``u64::from_str_radix(text, 16).unwrap_or(0)``."""
    digits = text[1:] if text.startswith("+") else text
    if not digits or any(c not in "0123456789abcdefABCDEF" for c in digits):
        return 0
    v = int(digits, 16)
    return v if v < 1 << 64 else 0


#: The most bytes any loader reads from one file: 64 GiB. A file is read
#: up to the size ``fstat`` gives when it is opened, and never past it; one
#: larger than this is refused before a byte is read (an ``svo.bin`` of the
#: format's 64 000 000 leaves takes under 3 GiB; probeplace's own reader
#: takes at most half the memory available).
MAX_FILE_BYTES = 1 << 36


def bytes_text(n: int) -> str:
    """``n`` bytes in words, as probeplace writes sizes (src/input.rs)."""
    if n < 1024:
        return f"{n} bytes"
    v, unit = n / 1024.0, 0
    units = ["KiB", "MiB", "GiB", "TiB", "PiB"]
    while v >= 1024.0 and unit + 1 < len(units):
        v /= 1024.0
        unit += 1
    digits = 0 if v >= 100.0 else 1 if v >= 10.0 else 2
    return f"{v:.{digits}f} {units[unit]}"


def kind_of(mode: int) -> "str | None":
    """What a file of ``mode`` is when it is not a regular file, in
    probeplace's words (src/input.rs, ``open``); ``None`` for a regular one."""
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if not stat.S_ISREG(mode):
        return "not a regular file"
    return None


def not_regular(name: str, what: str, mode: int) -> "ProbeplaceError | None":
    """The error for a ``what`` at ``name`` of ``mode`` that is not a
    regular file, as probeplace words it; ``None`` for a regular file."""
    kind = kind_of(mode)
    return None if kind is None else ProbeplaceError(
        f"{name}: is {kind}, not a {what} (a regular file)")


def read_file(path: "str | os.PathLike[str]", what: str, limit: "int | None" = None) -> bytes:
    """The bytes of ``path`` (a ``what``: "svo.bin", …); a file that cannot
    be read is a :class:`ProbeplaceError` naming it, in probeplace's words.

    As probeplace's own reader (src/input.rs): the file is opened
    non-blocking and checked with ``fstat`` on the open descriptor, so a
    FIFO without a writer neither blocks nor slips through a race between a
    check and the open, and ``/dev/zero`` is never read; anything but a
    regular file is refused. At most the size ``fstat`` gave is read, and a
    file over ``limit`` bytes (:data:`MAX_FILE_BYTES` when ``None``) is
    refused before a byte is read: memory stays bounded whatever the path
    names.
    """
    name = os.fspath(path)
    if limit is None:
        limit = MAX_FILE_BYTES
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise ProbeplaceError(f"{name}: {what} not found") from None
    except IsADirectoryError:
        raise ProbeplaceError(f"{name}: is a directory, not a {what}") from None
    except (OSError, ValueError) as e:
        if os.path.isdir(name):
            raise ProbeplaceError(f"{name}: is a directory, not a {what}") from None
        why = getattr(e, "strerror", None) or e
        raise ProbeplaceError(f"{name}: cannot read {what}: {why}") from None
    try:
        st = os.fstat(fd)
        refused = not_regular(name, what, st.st_mode)
        if refused is not None:
            raise refused
        if st.st_size > limit:
            raise ProbeplaceError(f"{name}: {what} is {bytes_text(st.st_size)}, "
                                  f"over the limit of {bytes_text(limit)}")
        chunks, left = [], st.st_size
        while left > 0:
            chunk = os.read(fd, min(left, 1 << 30))
            if not chunk:
                break  # shrunk since fstat: the format's checks say truncated
            chunks.append(chunk)
            left -= len(chunk)
        return chunks[0] if len(chunks) == 1 else b"".join(chunks)
    except OSError as e:
        raise ProbeplaceError(f"{name}: cannot read {what}: {e.strerror or e}") from None
    finally:
        os.close(fd)
