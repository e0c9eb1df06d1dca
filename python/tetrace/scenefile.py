"""The scene file format: a versioned, endian-explicit container of checksummed arrays.

:meth:`tetrace.Scene.save`, :meth:`tetrace.Scene.load`, pickling and ``copy.deepcopy`` all
go through :func:`pack` and :func:`unpack`; ``docs/save_format.md`` describes the bytes.
This module knows the container only (arrays and a JSON ``meta`` object); what a scene puts
in it is :meth:`tetrace.Scene.to_bytes`'s business. Imports only numpy and the standard
library.

Layout (all integers little-endian)::

    MAGIC                 12 bytes  b"\\x89TETRACE\\r\\n\\x1a\\n"
    format version        u32       FORMAT_VERSION
    header length         u64       bytes of the JSON header
    header CRC32          u32       zlib.crc32 of the JSON header
    header                UTF-8 JSON: package version, data length, arrays, meta
    padding               zeros up to a multiple of 8
    data                  the arrays, each at its offset (from the start of data, 8-aligned)

Each array's header entry gives ``name``, ``dtype`` (``"<f8"``, ``"<u4"``, ``"|u1"``, ...),
``shape``, ``offset``, ``nbytes`` and ``crc32`` (of its bytes).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import struct
import zlib

import numpy as np

from .errors import SceneFileError, SceneFileNotFoundError

__all__ = [
    "MAGIC",
    "FORMAT_VERSION",
    "pack",
    "unpack",
    "encode",
    "decode",
    "read_bytes",
    "write_bytes",
]

#: The first bytes of every scene file (PNG-style: a non-ASCII byte, then line endings and
#: a DOS end-of-file, so that text-mode transfers are caught).
MAGIC = b"\x89TETRACE\r\n\x1a\n"
#: The newest format version this build writes and reads. Version 2 lets a scene be saved
#: without its tetrahedralization (``meta["tetrahedralization"]`` null: a lazy scene, meshed
#: when a query needs it); a scene with one is written as version 1, which older builds read.
FORMAT_VERSION = 2

_PREFIX = struct.Struct("<IQI")  # version, header length, header CRC32
_ALIGN = 8
#: Array element kinds a file may hold (no objects, no strings).
_KINDS = "biuf"


def _pad(n):
    return -n % _ALIGN


def pack(arrays, meta, *, package_version="", version=FORMAT_VERSION):
    """Serialize named arrays and a JSON-able ``meta`` object.

    Parameters
    ----------
    arrays : dict of str to numpy.ndarray
        Numeric or bool arrays, written little-endian in C order.
    meta : dict
        Anything :func:`json.dumps` takes (``NaN``/``Infinity`` allowed).
    package_version : str
        The writer's tetrace version, recorded in the header.
    version : int
        The format version to record: the oldest that describes ``meta`` (so that older
        builds read what they can), at most :data:`FORMAT_VERSION`.

    Returns
    -------
    bytes
    """
    entries, blobs, offset = [], [], 0
    for name, a in arrays.items():
        a = np.asarray(a)
        if a.dtype.kind not in _KINDS:
            raise TypeError(f"array {name!r}: dtype {a.dtype} cannot be saved")
        le = np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("<"))
        data = le.tobytes()
        entries.append(
            dict(
                name=name,
                dtype=le.dtype.str,
                shape=list(le.shape),
                offset=offset,
                nbytes=len(data),
                crc32=zlib.crc32(data),
            )
        )
        blobs.append(data)
        blobs.append(b"\0" * _pad(len(data)))
        offset += len(data) + _pad(len(data))
    header = json.dumps(
        dict(
            package="tetrace", version=package_version, data_bytes=offset, arrays=entries, meta=meta
        ),
        separators=(",", ":"),
        allow_nan=True,
    ).encode("utf-8")
    if not 1 <= version <= FORMAT_VERSION:
        raise ValueError(f"format version {version} is not one this build writes")
    head = MAGIC + _PREFIX.pack(version, len(header), zlib.crc32(header)) + header
    return b"".join([head, b"\0" * _pad(len(head)), *blobs])


def unpack(buf, *, source="<bytes>"):
    """Read what :func:`pack` wrote, checking every length and checksum.

    Parameters
    ----------
    buf : bytes-like
    source : str
        How to name the data in error messages (a path).

    Returns
    -------
    arrays : dict of str to numpy.ndarray
        Read-only views in native byte order where it is little-endian (copies otherwise).
    meta : dict
    header : dict
        The whole header (``version``: the writer's package version).

    Raises
    ------
    tetrace.SceneFileError
        Not a scene file, a newer format version, a truncated or corrupt file; the message
        names ``source`` and what is wrong.
    """
    buf = memoryview(buf).cast("B")
    size = len(buf)

    def fail(what):
        raise SceneFileError(f"{source}: {what}")

    if size < len(MAGIC) or bytes(buf[: len(MAGIC)]) != MAGIC:
        if MAGIC.startswith(bytes(buf[: len(MAGIC)])):
            fail(f"truncated: {size} bytes, not even the {len(MAGIC)}-byte magic")
        fail(f"not a tetrace scene file (magic {bytes(buf[: len(MAGIC)])!r}, want {MAGIC!r})")
    start = len(MAGIC)
    if size < start + _PREFIX.size:
        fail(f"truncated: {size} bytes, the file header needs {start + _PREFIX.size}")
    version, header_len, header_crc = _PREFIX.unpack_from(buf, start)
    if version > FORMAT_VERSION:
        fail(
            f"format version {version} is newer than this tetrace reads "
            f"(format version {FORMAT_VERSION}); upgrade tetrace to load it"
        )
    if version < 1:
        fail(f"format version {version} is not a valid version")
    start += _PREFIX.size
    if header_len > size - start:
        fail(f"truncated: {size} bytes, the JSON header alone needs {start + header_len}")
    raw = bytes(buf[start : start + header_len])
    if zlib.crc32(raw) != header_crc:
        fail(f"corrupt header: CRC32 {zlib.crc32(raw):#010x}, the file says {header_crc:#010x}")
    try:
        header = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        fail(f"corrupt header: not UTF-8 JSON ({exc})")
    if not isinstance(header, dict) or not isinstance(header.get("arrays"), list):
        fail("corrupt header: no array table")
    start += header_len
    start += _pad(start)
    try:
        data_bytes = int(header["data_bytes"])
        entries = header["arrays"]
        meta = header["meta"]
    except (KeyError, TypeError, ValueError) as exc:
        fail(f"corrupt header: missing field {exc}")
    if size < start + data_bytes:
        fail(f"truncated: {size} bytes, header and arrays need {start + data_bytes}")
    if size > start + data_bytes:
        fail(f"{size - start - data_bytes} unexpected bytes after the arrays")
    arrays = {}
    for e in entries:
        try:
            name, dtype = str(e["name"]), np.dtype(e["dtype"])
            shape = tuple(int(s) for s in e["shape"])
            offset, nbytes, crc = int(e["offset"]), int(e["nbytes"]), int(e["crc32"])
        except (KeyError, TypeError, ValueError) as exc:
            fail(f"corrupt header: bad array entry {e!r} ({exc})")
        if dtype.kind not in _KINDS or dtype.byteorder == ">" or min(shape, default=0) < 0:
            fail(f"array {name!r}: unsupported dtype {dtype.str} or shape {shape}")
        if math.prod(shape) * dtype.itemsize != nbytes:
            fail(f"array {name!r}: shape {shape} of {dtype.str} is not {nbytes} bytes")
        if offset < 0 or offset + nbytes > data_bytes:
            fail(f"array {name!r}: bytes {offset}..{offset + nbytes} lie outside the data")
        chunk = buf[start + offset : start + offset + nbytes]
        if zlib.crc32(chunk) != crc:
            fail(f"array {name!r} is corrupt: CRC32 {zlib.crc32(chunk):#010x}, want {crc:#010x}")
        a = np.frombuffer(chunk, dtype=dtype).reshape(shape)
        if not dtype.isnative:
            a = a.astype(dtype.newbyteorder("="))
        arrays[name] = a
    return arrays, meta, header


def encode(value, arrays, path, seen=None):
    """``value`` as JSON-able data, its numpy arrays moved into ``arrays``.

    Arrays become ``{"__array__": name}`` (``name`` is ``path`` or, for an array object
    already stored, that one's name: shared arrays are stored once), tuples
    ``{"__tuple__": [...]}``, dicts whose keys are not all plain strings
    ``{"__items__": [[key, value], ...]}``, numpy scalars Python scalars, dataclass
    instances the dict of their fields; anything else its ``{"__repr__": ...}`` (read back
    as that string).
    """
    seen = {} if seen is None else seen
    if isinstance(value, np.ndarray):
        name = seen.get(id(value))
        if name is None:
            name = seen[id(value)] = path
            arrays[name] = value
        return {"__array__": name}
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, tuple):
        return {"__tuple__": [encode(v, arrays, f"{path}/{i}", seen) for i, v in enumerate(value)]}
    if isinstance(value, list):
        return [encode(v, arrays, f"{path}/{i}", seen) for i, v in enumerate(value)]
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        if all(isinstance(k, str) and not k.startswith("__") for k in value):
            return {k: encode(v, arrays, f"{path}/{k}", seen) for k, v in value.items()}
        return {
            "__items__": [
                [encode(k, arrays, f"{path}/key{i}", seen), encode(v, arrays, f"{path}/{i}", seen)]
                for i, (k, v) in enumerate(value.items())
            ]
        }
    return {"__repr__": repr(value)}


def decode(value, arrays):
    """The inverse of :func:`encode` (arrays looked up by name in ``arrays``).

    Raises
    ------
    KeyError
        An ``__array__`` names no array of ``arrays``.
    """
    if isinstance(value, list):
        return [decode(v, arrays) for v in value]
    if not isinstance(value, dict):
        return value
    if len(value) == 1:
        ((key, inner),) = value.items()
        if key == "__array__":
            return arrays[inner]
        if key == "__tuple__":
            return tuple(decode(v, arrays) for v in inner)
        if key == "__items__":
            return {decode(k, arrays): decode(v, arrays) for k, v in inner}
        if key == "__repr__":
            return inner
    return {k: decode(v, arrays) for k, v in value.items()}


def write_bytes(target, data):
    """Write ``data`` to a path (str or os.PathLike) or a binary file object."""
    if hasattr(target, "write"):
        target.write(data)
        return
    path = os.fspath(target)
    tmp = f"{path}.tmp-{os.getpid()}"
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def read_bytes(source):
    """Read all bytes of a path or a binary file object, and a name for error messages.

    Raises
    ------
    tetrace.SceneFileError
        The path is missing, a directory or unreadable (also a ``FileNotFoundError`` when
        it is missing).
    """
    if hasattr(source, "read"):
        data = source.read()
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"the file object must be opened in binary mode, got {type(data)}")
        return data, str(getattr(source, "name", "<file object>"))
    path = os.fspath(source)
    try:
        with open(path, "rb") as f:
            return f.read(), path
    except FileNotFoundError:
        raise SceneFileNotFoundError(f"{path}: no such scene file", path) from None
    except IsADirectoryError:
        raise SceneFileError(f"{path}: is a directory, not a scene file") from None
    except OSError as exc:
        raise SceneFileError(f"{path}: cannot be read ({exc.strerror or exc})") from None
