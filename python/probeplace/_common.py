"""What the three readers share: the error class, the provenance, the hashes."""

from __future__ import annotations

import os
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


def read_file(path: "str | os.PathLike[str]", what: str) -> bytes:
    """The bytes of ``path`` (a ``what``: "svo.bin", …); a file that cannot
    be read is a :class:`ProbeplaceError` naming it, in probeplace's words."""
    name = os.fspath(path)
    try:
        with open(path, "rb") as f:
            return f.read()
    except FileNotFoundError:
        raise ProbeplaceError(f"{name}: {what} not found") from None
    except IsADirectoryError:
        raise ProbeplaceError(f"{name}: is a directory, not a {what}") from None
    except OSError as e:
        raise ProbeplaceError(f"{name}: cannot read {what}: {e.strerror or e}") from None
