"""A beliefloc ``.npz`` file read without trusting it: the zip directory, the JSON header and each
array checked before use, never unpickled.

Each member's size is taken from the zip directory and its ``.npy`` header and checked against
:data:`~beliefloc.source.limits.MODEL_FILE_BYTES` before a byte is decompressed; the header's format and
version are checked before anything else is read (:func:`open_versioned`). Model files
(:mod:`beliefloc.files.model_file`) and macro tables (:mod:`beliefloc.files.macro_file`) are both such archives.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import mmap
import os
import stat
import struct
import threading
import zipfile
import zlib
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError

from beliefloc.errors import BeliefLocError, ModelError
from beliefloc.source import limits

_HEADER_KEY = "header"
_ANY_LABEL = "beliefloc file"
_LISTED = 8
"""How many array names a message lists."""

_DECODE_ERRORS: tuple[type[BaseException], ...] = (
    OSError,
    ValueError,
    EOFError,
    zipfile.BadZipFile,
    zlib.error,
    NotImplementedError,
    RuntimeError,  # an encrypted member
    struct.error,
    OverflowError,
    KeyError,
)
try:  # pragma: no cover - lzma is optional in a Python build
    import lzma

    _DECODE_ERRORS = (*_DECODE_ERRORS, lzma.LZMAError)
except ImportError:  # pragma: no cover
    pass


class _Prelude(BaseModel):
    """What is read of a header before knowing what it is: its format and version."""

    model_config = ConfigDict(extra="ignore")
    format: Any = None
    version: Any = None


_READ_CHUNK = 2**20
"""Bytes of an array read (and inflated) at a time."""
_MADV_POPULATE_READ = 22
"""Linux's ``madvise`` advice that maps a range's pages readable without faults (Python 3.11's ``mmap`` has no
name for it)."""

_LOCAL_HEADER = 30
"""Bytes of a zip member's local header before its name and extra field."""


class Archive:
    """A beliefloc ``.npz`` file opened for reading: the zip directory checked, the JSON header read
    and of the expected format and version; arrays are read on demand, each checked as it is read.
    Made by :func:`open_versioned`."""

    def __init__(
        self, path: Path, archive: zipfile.ZipFile, members: dict[str, zipfile.ZipInfo], rebuild: str, label: str
    ) -> None:
        self.path = path
        self.label = label
        self._zip = archive
        self.members = members
        """The ``.npy`` members by key (``header`` excluded once read)."""
        self.rebuild = rebuild
        self.header_bytes = b""
        self._map: mmap.mmap | None = None
        self._unmappable = False
        self._lock = threading.Lock()
        """Held while the file's handle is read: threads may read members side by side (a model's
        transitions are checked on two cores), each member's bytes read by one at a time."""

    def broken(self, what: str) -> ModelError:
        """The error for a file whose content is not what a beliefloc file holds."""
        return ModelError(f"{self.path}: broken {self.label}: {what}; rebuild it with '{self.rebuild}'")

    def validate(self, schema: type[_H]) -> _H:
        """The header validated with the pydantic model ``schema``; an error names the field."""
        try:
            return schema.model_validate_json(self.header_bytes)
        except ValidationError as exc:
            error = exc.errors()[0]
            field = _field_name(error["loc"])
            where = f"header field {field}" if field else "the header"
            raise self.broken(f"{where}: {error['msg']}") from None

    def expect(self, keys: Sequence[str]) -> None:
        """Refuse an archive that does not hold exactly the arrays ``keys``."""
        wanted = set(keys)
        missing = [key for key in keys if key not in self.members]
        if missing:
            raise self.broken(f"missing arrays: {_listing(missing)}")
        extra = sorted(set(self.members) - wanted)
        if extra:
            raise self.broken(f"unexpected arrays: {_listing(extra)}")

    def array(self, key: str, kinds: str, shape: Sequence[int | None]) -> np.ndarray:
        """Member ``key``, checked against its ``.npy`` header before it is read: a dtype of one of
        ``kinds`` (numpy kind letters: ``b`` bool, ``i``/``u`` integers, ``f`` floats) and ``shape``
        (None: any length). Booleans come back as 0/1 booleans, other types in native byte order."""
        info = self.members[key]
        unchecked: memoryview | None = None
        try:
            with self._lock, self._zip.open(info) as stream:
                version = np.lib.format.read_magic(stream)
                if version == (1, 0):
                    found, fortran, dtype = np.lib.format.read_array_header_1_0(stream)
                elif version == (2, 0):
                    found, fortran, dtype = np.lib.format.read_array_header_2_0(stream)
                else:
                    raise self.broken(f"array {key}: .npy format version {version[0]}.{version[1]} is not supported")
                self._check_type(key, dtype, kinds, found, shape)
                nbytes = math.prod(found) * dtype.itemsize
                offset = stream.tell()
                if info.file_size != offset + nbytes:
                    raise self.broken(
                        f"array {key}: its header announces {nbytes:,} bytes of data but the archive member "
                        f"holds {info.file_size - offset:,}"
                    )
                count = math.prod(found)
                stored = info.compress_type == zipfile.ZIP_STORED and info.compress_size == info.file_size
                if stored:
                    # stored, not deflated (``beliefloc build --uncompressed``): mapped from the file or
                    # read straight into the array, no zlib and no copy through zipfile's buffers
                    buffer, unchecked = self._stored(key, info, offset, dtype, count)
                else:
                    buffer = self._inflated(key, stream, dtype, count)
        except BeliefLocError:
            raise
        except _DECODE_ERRORS as exc:
            raise self.broken(f"array {key} cannot be read ({_reason(exc)})") from None
        # a mapped member's checksum, with the handle free for another thread's member (0.05 s a 240 MB array)
        if unchecked is not None and zlib.crc32(unchecked) != info.CRC:
            raise self.broken(f"array {key}: its data does not match its checksum (CRC-32)")
        array = buffer
        if dtype.kind == "b":
            array = array.view(np.uint8) != 0  # a bool byte other than 0 or 1 is not a bool
        elif not dtype.isnative:
            array = array.astype(dtype.newbyteorder("="))
        if array.shape == found:
            return array  # a vector: the array itself, owning its memory or mapping the file (a reshape is a view)
        return array.reshape(found, order="F" if fortran else "C")

    def _inflated(self, key: str, stream: Any, dtype: np.dtype[Any], count: int) -> np.ndarray:
        """The array data that follows the ``.npy`` header in the zipfile ``stream``, inflated."""
        nbytes = count * dtype.itemsize
        # numpy's memory, not a bytearray: uninitialised (a bytearray is zeroed first) and, at 4 MB
        # and up, in huge pages (numpy asks the kernel for them): a page fault per 2 MB, not per 4 kB.
        # The array owns it (no view of a byte buffer: SciPy copies an index array that is a view of
        # a larger base, 0.6 s for a 10^7-state model's four transitions)
        buffer = np.empty(count, dtype=dtype)
        view = buffer.view(np.uint8).data  # a memoryview of its bytes
        done = 0
        while done < nbytes:
            # a MiB at a time: asked for all of it, zipfile inflates the whole member into one new
            # bytes object first (its page faults, then a copy: 0.4-0.9 s for a 152 MB array, against
            # 0.1 s in MiB pieces whose memory malloc reuses)
            got = stream.readinto(view[done : done + _READ_CHUNK])
            if not got:
                raise self.broken(f"array {key}: the data ends after {done:,} of {nbytes:,} bytes")
            done += got
        return buffer

    def _stored(
        self, key: str, info: zipfile.ZipInfo, offset: int, dtype: np.dtype[Any], count: int
    ) -> tuple[np.ndarray, memoryview | None]:
        """A stored member's array data (after its ``offset`` bytes of ``.npy`` header), and the bytes whose
        CRC-32 the caller must check as zipfile would (7 GB/s: 0.02 s at 10^6 states), or None when they were
        checked here (read, not mapped).

        Data that starts at a multiple of its type's alignment in the file (every array
        :func:`write_stored` writes) is *mapped*: the array is the file's pages in the page cache,
        private (copy on write), with no copy and no fresh memory to fault in and zero (130 MB at
        10^6 states, 1.3 GB at 10^7). The mapping outlives the file's handle; files are replaced,
        never written over, by :mod:`beliefloc.source.atomic_write`. Other stored data is read
        straight from the file into a new array."""
        handle = self._zip.fp
        assert handle is not None
        handle.seek(info.header_offset)
        local = handle.read(_LOCAL_HEADER)
        if len(local) != _LOCAL_HEADER or local[:4] != b"PK\x03\x04":
            raise self.broken(f"array {key}: its zip entry has no local header")
        name_length, extra_length = struct.unpack("<HH", local[26:30])
        start = info.header_offset + _LOCAL_HEADER + name_length + extra_length
        nbytes = count * dtype.itemsize
        mapped = self._mapped() if (start + offset) % dtype.alignment == 0 and nbytes else None
        if mapped is not None:
            end = start + offset + nbytes
            if end > len(mapped):
                raise self.broken(
                    f"array {key}: the data ends after {max(0, len(mapped) - start - offset):,} of {nbytes:,} bytes"
                )
            return np.frombuffer(mapped, dtype=dtype, count=count, offset=start + offset), memoryview(mapped)[start:end]
        handle.seek(start)
        crc = zlib.crc32(handle.read(offset))
        buffer = np.empty(count, dtype=dtype)
        view = buffer.view(np.uint8).data
        done = 0
        while done < nbytes:
            got = handle.readinto(view[done:])  # type: ignore[attr-defined]
            if not got:
                raise self.broken(f"array {key}: the data ends after {done:,} of {nbytes:,} bytes")
            done += got
        if zlib.crc32(view, crc) != info.CRC:
            raise self.broken(f"array {key}: its data does not match its checksum (CRC-32)")
        return buffer, None

    def _mapped(self) -> mmap.mmap | None:
        """The whole file mapped privately (copy on write), once; None where it cannot be."""
        if self._map is None and not self._unmappable:
            handle = self._zip.fp
            try:
                assert handle is not None
                self._map = mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_COPY)
            except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
                self._unmappable = True
            else:
                # every member is read (its CRC-32): its pages mapped in one call, not a fault each (the
                # 1.3 GB of 10^7 states: CRC-32 over the mapping 0.34-0.36 s, 0.29 s with it). Read-only
                # population keeps the mapping's pages shared with the page cache (copy on write as before)
                with contextlib.suppress(OSError, ValueError):
                    self._map.madvise(_MADV_POPULATE_READ)  # Linux 5.14 and later; elsewhere the faults as before
        return self._map

    def _check_type(
        self, key: str, dtype: np.dtype[Any], kinds: str, found: tuple[int, ...], shape: Sequence[int | None]
    ) -> None:
        if dtype.hasobject or dtype.fields is not None or dtype.subdtype is not None:
            raise self.broken(f"array {key} holds Python objects or records ({dtype}); beliefloc files hold numbers")
        if dtype.kind not in kinds or dtype.itemsize > 8:
            expected = " or ".join(_KIND_NAMES[k] for k in kinds)
            raise self.broken(f"array {key} holds {dtype}, not {expected}")
        if len(found) != len(shape) or any(want not in (None, got) for want, got in zip(shape, found, strict=True)):
            sizes = ", ".join("n" if s is None else str(s) for s in shape)
            wanted = f"({sizes},)" if len(shape) == 1 else f"({sizes})"
            raise self.broken(f"array {key} has shape {found}, expected {wanted}")

    def read_header(self) -> None:
        header = self.array(_HEADER_KEY, "u", (None,))
        if header.dtype != np.uint8:
            raise self.broken(f"array {_HEADER_KEY} holds {header.dtype}, not bytes (uint8)")
        self.header_bytes = header.tobytes()

    def integers(self, key: str, shape: Sequence[int | None]) -> np.ndarray:
        """Integer member ``key``: int32 and int64 as saved (a model's fingerprint hashes its CSR
        arrays as saved), any other integer type as int64, once its values are known to fit."""
        array = self.array(key, "iu", shape)
        if array.dtype in (np.int32, np.int64):
            return array
        if array.dtype == np.uint64 and array.size and int(array.max()) > np.iinfo(np.int64).max:
            raise self.broken(f"array {key}: {int(array.max())} is out of range")
        return array.astype(np.int64)


_H = TypeVar("_H", bound=BaseModel)

_KIND_NAMES = {"b": "booleans", "i": "integers", "u": "integers", "f": "floating-point numbers"}


def _field_name(loc: Sequence[str | int]) -> str:
    """``actions[2].cost`` for pydantic's ``('actions', 2, 'cost')``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def _listing(names: Sequence[str]) -> str:
    shown = ", ".join(names[:_LISTED])
    return shown + (f", ... ({len(names)} in all)" if len(names) > _LISTED else "")


def _reason(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror.lower()
    return str(exc) or type(exc).__name__


@contextlib.contextmanager
def open_versioned(
    path: str | Path,
    file_format: str,
    version: int,
    *,
    label: str,
    kind: str,
    rebuild: str,
    older: Sequence[int] = (),
) -> Iterator[Archive]:
    """The beliefloc ``.npz`` file ``path`` of ``file_format`` and ``version``, header read (see
    :class:`Archive`). A :class:`ModelError` for a missing file, something that is not a zip
    archive (not a ``label``), an archive of other arrays (not ``kind``, a noun phrase of
    :mod:`beliefloc.source.file_kinds`), a beliefloc file of another kind (named), and another version
    than ``version`` and ``older`` (``rebuild`` says how to make a new one); a
    :class:`~beliefloc.errors.LimitError` for an archive larger than the limits, told from its directory
    before anything is decompressed."""
    path = Path(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ModelError(f"{path}: no such file") from None
    except (OSError, ValueError) as exc:
        raise ModelError(f"{path}: cannot read it ({_reason(exc)})") from None
    if stat.S_ISDIR(info.st_mode):
        raise ModelError(f"{path}: is a folder, not a {label}")
    if not stat.S_ISREG(info.st_mode):
        raise ModelError(f"{path}: not a regular file, so not a {label}")
    limits.MODEL_FILE_BYTES.check(info.st_size, str(path))
    try:
        handle = open(path, "rb")  # noqa: SIM115 - closed below, after the archive
    except OSError as exc:
        raise ModelError(f"{path}: cannot read it ({_reason(exc)})") from None
    with handle:
        _directory(path, handle, label)
        try:
            archive = zipfile.ZipFile(handle)
        except _DECODE_ERRORS as exc:
            raise ModelError(f"{path}: not a {label} ({_reason(exc)})") from None
        with archive:
            opened = Archive(path, archive, {}, rebuild, label)
            opened.members = _members(opened, archive, kind)
            opened.read_header()
            del opened.members[_HEADER_KEY]
            _check_prelude(opened, file_format, version, kind, rebuild, older)
            yield opened


_ALIGN = 64
"""Stored arrays' data start at a multiple of this many bytes in the file (:func:`write_stored`)."""
_PADDING_ID = 0xD935
"""The zip extra field that pads a local header (the id Android's ``zipalign`` uses)."""


def write_stored(handle: Any, arrays: dict[str, np.ndarray]) -> None:
    """Write ``arrays`` to the open binary file ``handle`` as an uncompressed ``.npz``, what
    ``np.savez`` writes, except that each array's data starts at a multiple of 64 bytes in the file:
    each member's local header is padded with an extra field. Any zip or ``.npz`` reader reads it;
    :class:`Archive` maps such arrays from the file instead of reading them (no copy)."""
    with zipfile.ZipFile(handle, mode="w", compression=zipfile.ZIP_STORED, allowZip64=True) as archive:
        for key, value in arrays.items():
            array = np.ascontiguousarray(value)
            header = io.BytesIO()
            fields = np.lib.format.header_data_from_array_1_0(array)
            try:
                np.lib.format.write_array_header_1_0(header, fields)
            except ValueError:  # pragma: no cover - a header over 64 kB
                header = io.BytesIO()
                np.lib.format.write_array_header_2_0(header, fields)
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_STORED
            name = info.filename.encode("utf-8")
            # the local header: 30 bytes, the name, this padding (4 bytes and the pad) and the zip64
            # field zipfile adds (20 bytes), then the .npy header, then the data
            before_data = archive.fp.tell() + _LOCAL_HEADER + len(name) + 4 + 20 + len(header.getvalue())  # type: ignore[union-attr]
            pad = -before_data % _ALIGN
            info.extra = struct.pack("<HH", _PADDING_ID, pad) + bytes(pad)
            with archive.open(info, "w", force_zip64=True) as member:
                member.write(header.getvalue())
                member.write(array.reshape(-1).view(np.uint8).data if array.size else b"")


def _directory(path: Path, handle: Any, label: str) -> None:
    """Check the number of members the zip directory announces against the limit, before the
    directory itself is read (a ModelError for a file that is not a zip archive)."""
    try:
        end = zipfile._EndRecData(handle)  # type: ignore[attr-defined]
    except _DECODE_ERRORS as exc:
        raise ModelError(f"{path}: not a {label} ({_reason(exc)})") from None
    if end is None:
        raise ModelError(f"{path}: not a {label} (not a zip archive, which a .npz file is)")
    count = int(end[zipfile._ECD_ENTRIES_TOTAL])  # type: ignore[attr-defined]
    limits.MODEL_FILE_ARRAYS.check(count, str(path))
    handle.seek(0)


def _members(archive: Archive, zipped: zipfile.ZipFile, kind: str) -> dict[str, zipfile.ZipInfo]:
    """The ``.npy`` members by key: an archive of other files is not ``kind``; sizes checked."""
    path = archive.path
    infos = zipped.infolist()
    limits.MODEL_FILE_ARRAYS.check(len(infos), str(path))
    members: dict[str, zipfile.ZipInfo] = {}
    others = []
    for info in infos:
        if info.filename.endswith(".npy"):
            key = info.filename[: -len(".npy")]
            if key in members:
                raise archive.broken(f"the archive holds array {key} twice")
            members[key] = info
        else:
            others.append(info.filename)
    total = sum(info.file_size for info in infos)
    limits.MODEL_FILE_BYTES.check(total, str(path))
    if _HEADER_KEY not in members:
        held = f"arrays: {_listing(sorted(members))}" if members else "no arrays"
        if others:
            held += f"; files: {_listing(sorted(others))}"
        raise ModelError(f"{path} is not {_beliefloc(kind)} (it holds {held})")
    if others:
        raise archive.broken(f"the archive holds files that are not arrays: {_listing(sorted(others))}")
    return members


def _beliefloc(kind: str) -> str:
    """``a beliefloc model`` for :data:`~beliefloc.source.file_kinds.MODEL` ``a compiled model``."""
    from beliefloc.source.file_kinds import MACROS, MODEL

    return {MODEL: "a beliefloc model", MACROS: "a beliefloc macro table"}.get(kind, kind)


def _written_prelude(file_format: str, version: int) -> bytes:
    """How a header that ``json.dumps`` wrote starts when its first fields are this format and version."""
    return json.dumps({"format": file_format, "version": version}).encode()[:-1] + b","


def _check_prelude(
    archive: Archive, file_format: str, version: int, kind: str, rebuild: str, older: Sequence[int] = ()
) -> None:
    from beliefloc.source.file_kinds import kind_of_data, not_a

    path = archive.path
    if any(archive.header_bytes.startswith(_written_prelude(file_format, v)) for v in (version, *older)):
        # the header as beliefloc writes it, of this format and version: pydantic would parse the whole
        # header for these two fields (0.4 s for a 10^7-state model's); the schema checks them again
        return
    try:
        prelude = _Prelude.model_validate_json(archive.header_bytes)
    except ValidationError as exc:
        raise ModelError(
            f"{path} is not {_beliefloc(kind)} (its header is not a JSON object: {exc.errors()[0]['msg']})"
        ) from None
    if prelude.format != file_format:
        found = kind_of_data({"format": prelude.format})
        if found is not None and found != kind:
            raise ModelError(not_a(path, found, kind) + _wrong_kind_hint(found))
        raise ModelError(f"{path} is not {_beliefloc(kind)} (its header says format {prelude.format!r})")
    if prelude.version != version and prelude.version not in older:
        raise ModelError(
            f"{path}: {kind.removeprefix('a ')} of version {prelude.version}, but this beliefloc reads version "
            f"{version}; rebuild it with '{rebuild}'"
        )


def _wrong_kind_hint(found: str) -> str:
    """What to do when handed a file of the other kind."""
    from beliefloc.source.file_kinds import MACROS, MODEL

    if found == MACROS:
        return "; give the map or the model it was built from, and the table with --macros"
    if found == MODEL:
        return "; a macro table is what 'beliefloc macros build MAP -o TABLE.npz' writes"
    return ""


def file_format(path: str | Path) -> str | None:
    """The ``format`` an existing ``.npz`` file's header names (``beliefloc-model``,
    ``beliefloc-macros``), or None when it is not a beliefloc archive or cannot be read. Reads
    only the header, with the same limits as a load."""
    path = Path(path)
    try:
        if not path.is_file():
            return None
        with open(path, "rb") as handle:
            _directory(path, handle, _ANY_LABEL)
            with zipfile.ZipFile(handle) as zipped:
                info = zipped.getinfo(f"{_HEADER_KEY}.npy")
                if info.file_size > 64 * 1024**2:
                    return None
                archive = Archive(path, zipped, {_HEADER_KEY: info}, "", _ANY_LABEL)
                archive.read_header()
        prelude = _Prelude.model_validate_json(archive.header_bytes)
    except (BeliefLocError, ValidationError):
        return None
    except _DECODE_ERRORS:
        return None
    return prelude.format if isinstance(prelude.format, str) else None
