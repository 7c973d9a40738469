"""Where a bag that does not open is damaged: the topic and message index at which its data stops.

A bag that rosbags cannot open (a ROS 1 bag cut before its index, an MCAP file cut before its footer, a ROS 2 sqlite3
database with damaged pages) still holds its messages in storage order up to the damage. :func:`locate_damage` walks
those records without the index — ROS 1 records and chunks, MCAP records and chunks, the sqlite3 ``messages`` table in
row order — counting the intact messages of each topic, and returns where the walk stopped:

* ``Damage(topic, index, inside=True)``: the record of message ``index`` (0-based in ``topic``) is cut;
* ``Damage(topic, index, inside=False)``: the walk stopped after message ``index`` of ``topic`` (the damage falls
  between records, so the next message's topic is unknown);
* ``None``: no message record was reached (a bag damaged in its first record, or not a bag).

Compressed chunks are decompressed incrementally, so a chunk cut in the middle still yields the records of its
complete compressed blocks (bz2 and lz4 blocks are large: a cut chunk usually yields none, and the walk names the
last message of the chunk before).
"""

from __future__ import annotations

import bz2
import mmap
import shutil
import sqlite3
import struct
import tempfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROS1_MAGIC = b"#ROSBAG V2.0\n"
MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True)
class Damage:
    """Where the data of a bag stops: message ``index`` (0-based) of ``topic``, cut (``inside``) or the last intact
    one before the damage; ``intact`` messages of every topic were read before it."""

    topic: str
    index: int
    inside: bool
    intact: int

    def describe(self) -> str:
        if self.inside:
            return f"topic {self.topic}, message {self.index}"
        return f"topic {self.topic}, after message {self.index}"


class _Walk:
    """Counts messages per topic as a walk meets them; ``cut`` remembers a message whose record is incomplete."""

    def __init__(self):
        self.topics: dict[int, str] = {}
        self.counts: Counter = Counter()
        self.last: str | None = None
        self.cut: str | None = None

    def message(self, channel: int, complete: bool) -> None:
        topic = self.topics.get(channel, f"<connection {channel}>")
        if not complete:
            self.cut = topic
            raise _Stop
        self.counts[topic] += 1
        self.last = topic

    def damage(self) -> Damage | None:
        intact = sum(self.counts.values())
        if self.cut is not None:
            return Damage(self.cut, self.counts[self.cut], True, intact)
        if self.last is not None:
            return Damage(self.last, self.counts[self.last] - 1, False, intact)
        return None


class _Stop(Exception):
    """The walk met the damage."""


def locate_damage(location: str | Path) -> Damage | None:
    """Where the messages of the bag at ``location`` (a ``.bag`` or ``.mcap`` file or a ROS 2 bag folder) stop."""
    location = Path(location)
    walk = _Walk()
    try:
        if location.is_dir():
            for db in sorted(location.glob("*.db3")):
                _walk_sqlite(db, walk)
            for mcap in sorted(location.glob("*.mcap")):
                _walk_file(mcap, walk)
        else:
            _walk_file(location, walk)
    except _Stop:
        pass
    except (OSError, ValueError, struct.error, EOFError):  # damage the walk cannot pass: it stops where it is
        pass
    return walk.damage()


def _walk_file(path: Path, walk: _Walk) -> None:
    """A ROS 1 bag or an MCAP file, mapped rather than read (a damaged bag can be large)."""
    with path.open("rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
        magic = data[: len(ROS1_MAGIC)]
        if magic == ROS1_MAGIC:
            _walk_ros1(data, walk)
        elif magic.startswith(MCAP_MAGIC):
            _mcap_walk_records(data, len(MCAP_MAGIC), walk, top=True)


# --- ROS 1: records of (header length, header fields, data length, data); op 5 chunks hold ops 7 (connection) and 2
def _fields(header: bytes) -> dict[str, bytes]:
    fields, pos = {}, 0
    while pos + 4 <= len(header):
        (size,) = struct.unpack_from("<I", header, pos)
        name, _, value = header[pos + 4 : pos + 4 + size].partition(b"=")
        fields[name.decode("latin-1")] = value
        pos += 4 + size
    return fields


def _ros1_records(data: bytes, pos: int, walk: _Walk):
    """The (fields, data) of each complete record from ``pos``; a cut message record is reported to ``walk``."""
    while pos < len(data):
        if pos + 4 > len(data):
            raise _Stop
        (header_len,) = struct.unpack_from("<I", data, pos)
        header = data[pos + 4 : pos + 4 + header_len]
        if len(header) < header_len:
            raise _Stop
        fields = _fields(header)
        pos += 4 + header_len
        body_len = struct.unpack_from("<I", data, pos)[0] if pos + 4 <= len(data) else None
        complete = body_len is not None and pos + 4 + body_len <= len(data)
        if fields.get("op") == b"\x02" and not complete:
            walk.message(struct.unpack("<I", fields["conn"])[0], complete=False)
        body = data[pos + 4 : pos + 4 + body_len] if body_len is not None else b""
        yield fields, body, complete
        if not complete:
            raise _Stop
        pos += 4 + body_len


def _ros1_inner(records: bytes, walk: _Walk) -> None:
    for fields, _, _ in _ros1_records(records, 0, walk):
        if fields.get("op") == b"\x07":
            walk.topics[struct.unpack("<I", fields["conn"])[0]] = fields["topic"].decode()
        elif fields.get("op") == b"\x02":
            walk.message(struct.unpack("<I", fields["conn"])[0], complete=True)


def _walk_ros1(data: bytes, walk: _Walk) -> None:
    for fields, body, complete in _ros1_records(data, len(ROS1_MAGIC), walk):
        if fields.get("op") == b"\x05":
            _ros1_inner(_decompressed(fields["compression"].decode(), body), walk)
            if not complete:
                raise _Stop
        elif fields.get("op") == b"\x07":
            walk.topics[struct.unpack("<I", fields["conn"])[0]] = fields["topic"].decode()


# --- MCAP: records of (opcode u8, length u64, content); 0x04 channel, 0x05 message, 0x06 chunk
def _mcap_records(data: bytes, pos: int):
    while pos + 9 <= len(data):
        op, length = data[pos], struct.unpack_from("<Q", data, pos + 1)[0]
        yield op, data[pos + 9 : pos + 9 + length], pos + 9 + length <= len(data)
        pos += 9 + length
    if pos < len(data):
        yield None, b"", False


def _mcap_walk_records(data: bytes, pos: int, walk: _Walk, top: bool) -> None:
    for op, content, complete in _mcap_records(data, pos):
        if op == 0x04 and complete:
            (channel,) = struct.unpack_from("<H", content, 0)
            (size,) = struct.unpack_from("<I", content, 4)
            walk.topics[channel] = content[8 : 8 + size].decode()
        elif op == 0x05:
            if len(content) < 2:
                raise _Stop
            walk.message(struct.unpack_from("<H", content, 0)[0], complete)
        elif op == 0x06 and top:
            (size,) = struct.unpack_from("<I", content, 28)
            compression = content[32 : 32 + size].decode()
            _mcap_walk_records(_decompressed(compression, content[32 + size + 8 :]), 0, walk, top=False)
        if not complete:
            raise _Stop


# --- ROS 2 sqlite3: the messages table in row order (the order written), until sqlite meets a damaged page
def _walk_sqlite(db: Path, walk: _Walk) -> None:
    """sqlite refuses a database shorter than its header's page count, so a cut one is walked in a copy padded with
    zero pages to that count: the pages that remain read, the first missing one stops the walk."""
    with db.open("rb") as f:
        head = f.read(100)
    page_size, pages = struct.unpack_from(">H", head, 16)[0], struct.unpack_from(">I", head, 28)[0]
    page_size = 65536 if page_size == 1 else page_size
    missing = page_size * pages - db.stat().st_size
    with tempfile.TemporaryDirectory() as scratch:
        if missing > 0:
            padded = Path(scratch) / db.name
            shutil.copyfile(db, padded)
            with padded.open("ab") as f:
                f.truncate(page_size * pages)
            db = padded
        _walk_sqlite_rows(db, walk)


def _walk_sqlite_rows(db: Path, walk: _Walk) -> None:
    connection = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        try:
            walk.topics.update(connection.execute("SELECT id, name FROM topics").fetchall())
        except sqlite3.DatabaseError:
            pass
        rows = connection.execute("SELECT topic_id, length(data) FROM messages ORDER BY rowid")
        while True:
            try:
                row = rows.fetchone()
            except sqlite3.DatabaseError:
                raise _Stop from None
            if row is None:
                return
            if row[0] not in walk.topics or not row[1]:  # a row read from a zeroed page: the damage
                raise _Stop
            walk.message(row[0], complete=True)
    except sqlite3.DatabaseError:
        raise _Stop from None
    finally:
        connection.close()


def _decompressed(compression: str, data: bytes) -> bytes:
    """As much of ``data`` as decompresses (a cut stream yields its beginning)."""
    return _DECOMPRESSORS.get(compression, _raw)(data)


def _raw(data: bytes) -> bytes:
    return bytes(data)


def _bz2(data: bytes) -> bytes:
    return bz2.BZ2Decompressor().decompress(data)


def _lz4(data: bytes) -> bytes:
    import lz4.frame

    return lz4.frame.LZ4FrameDecompressor().decompress(data)


def _zstd(data: bytes) -> bytes:
    try:  # rosbags' own zstd: the standard library's from Python 3.14, its backport before
        from compression import zstd
    except ImportError:
        from backports import zstd

    return zstd.ZstdDecompressor().decompress(data)


_DECOMPRESSORS: dict[str, Callable[[bytes], bytes]] = {"": _raw, "none": _raw, "bz2": _bz2, "lz4": _lz4, "zstd": _zstd}
