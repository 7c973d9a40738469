"""Reading ROS bags with ``rosbags`` (no ROS installation): open a bag, pick topics, take their messages and stamps.

A bag is a ROS 1 ``.bag`` file, a ROS 2 bag folder (``metadata.yaml`` with sqlite3 ``.db3`` or ``.mcap`` storage;
the folder or its ``metadata.yaml`` may be named) or a bare ``.mcap`` file. ROS 1 bags and ROS 2 bags written with
their message definitions deserialize with those; other ROS 2 bags with the ROS 2 Humble type store.

Every failure — a file that does not open (truncated, not a bag), a topic that is absent or of another type, a
message that does not deserialize, stamps that step back — is a :class:`~slamarena.datasets.errors.DataFormatError`
naming the bag, the topic and the 0-based index of the message in that topic (:func:`bag_error`); for a bag that
does not open, the message where its data stops (:func:`~slamarena.datasets.formats.bag_damage.locate_damage`).

Stamps (:class:`TopicMessages`): ``receive`` is the bag's record time of each message; ``header`` the message's
``header.stamp`` (NaN for a type without a header, e.g. ``geometry_msgs/Twist``; a topic whose header stamps are all
zero falls back to its receive times, :meth:`TopicMessages.stamp_source`); both in seconds, and exactly as
integer nanoseconds (``receive_ns``, ``header_ns``).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DataFormatError
from .bag_damage import locate_damage

__all__ = ["TopicMessages", "bag_error", "bag_location", "open_bag", "read_topic", "pick_topic", "header_ns"]


def bag_error(bag: str | Path, topic: str | None, index: int | None, expected: str, got: str | None = None):
    """A :class:`DataFormatError` located at ``bag``, topic ``topic``, message ``index`` (0-based in the topic)."""
    where = str(bag)
    if topic is not None:
        where += f", topic {topic}"
    if index is not None:
        where += f", message {index}"
    return DataFormatError(where, None, expected, got)


def bag_location(path: str | Path) -> Path:
    """The path rosbags opens: a ROS 2 bag's folder when its ``metadata.yaml`` is named, else ``path``."""
    path = Path(path)
    return path.parent if path.name == "metadata.yaml" else path


@contextmanager
def open_bag(path: str | Path) -> Iterator:
    """An open :class:`rosbags.highlevel.AnyReader` of the bag at ``path`` (errors as :class:`DataFormatError`)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    location = bag_location(path)
    if not location.exists():
        raise bag_error(location, None, None, "a ROS bag (.bag file, ROS 2 bag folder or .mcap file)", "no such path")
    try:
        reader = AnyReader([location], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:  # rosbags raises its own error classes, struct and OS errors for damaged files
        raise _unreadable(location, exc) from None
    try:
        yield reader
    finally:
        reader.close()


def _unreadable(location: Path, exc: Exception) -> DataFormatError:
    """The error for a bag that does not open, located at the message where its data stops (when it has any)."""
    got = f"{type(exc).__name__}: {exc}"
    damage = locate_damage(location)
    if damage is None:
        return bag_error(location, None, None, "a readable ROS bag", got)
    return DataFormatError(
        f"{location}, {damage.describe()}",
        None,
        "a readable ROS bag",
        f"{got} ({damage.intact} messages intact before the damage)",
    )


@dataclass(frozen=True)
class TopicMessages:
    """The messages of one topic in bag order, with their receive and header stamps [ns] (``header_ns`` None when
    a message has no header)."""

    bag: str
    topic: str
    msgtype: str
    receive_ns: np.ndarray
    header_ns: np.ndarray | None
    messages: list

    @property
    def receive(self) -> np.ndarray:
        return self.receive_ns / 1e9

    @property
    def header(self) -> np.ndarray:
        return np.full(len(self), np.nan) if self.header_ns is None else self.header_ns / 1e9

    def __len__(self) -> int:
        return len(self.messages)

    def stamps(self, source: str) -> np.ndarray:
        """The stamps of ``source`` ("header" or "receive"); a type without a header always gives its receive time."""
        return self.header if self.stamp_source(source) == "header" else self.receive

    def stamp_source(self, source: str) -> str:
        """``"header"`` when asked for and every message has a header stamp, not all of them zero (a publisher that
        leaves its headers unset); else ``"receive"``."""
        usable = self.header_ns is not None and bool(np.any(self.header_ns != 0))
        return "header" if source == "header" and usable else "receive"

    def monotonic(self, source: str) -> np.ndarray:
        """The stamps of ``source``, checked non-decreasing (else the error names the first message stepping back)."""
        t = self.stamps(source)
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size:
            k = int(back[0]) + 1
            raise bag_error(
                self.bag,
                self.topic,
                k,
                f"non-decreasing {self.stamp_source(source)} stamps (previous {t[k - 1]!r} s)",
                f"{t[k]!r} s",
            )
        return t


def _normalized(msgtype: str) -> str:
    """``pkg/Type`` and ``pkg/msg/Type`` alike, as ``pkg/msg/Type`` (rosbags' spelling)."""
    pkg, _, name = msgtype.rpartition("/")
    pkg = pkg.split("/")[0]
    return f"{pkg}/msg/{name}"


def pick_topic(
    reader, topic: str | None, msgtypes: tuple[str, ...], role: str, exclude: tuple[str | None, ...] = ()
) -> str | None:
    """The topic to read for ``role``: ``topic`` when given (it must exist and have one of ``msgtypes``), else the one
    topic of one of those types not in ``exclude`` (None when there is none; an error when there are several)."""
    wanted = {_normalized(m) for m in msgtypes}
    types = {c.topic: c.msgtype for c in reader.connections}
    bag = bag_location(reader.paths[0])
    if topic is not None:
        if topic not in types:
            raise bag_error(
                bag, topic, None, f"a topic {topic} for {role}", f"none; topics: {', '.join(sorted(types))}"
            )
        if types[topic] not in wanted:
            raise bag_error(
                bag, topic, None, f"a message of type {' or '.join(sorted(wanted))} for {role}", types[topic]
            )
        return topic
    found = sorted(t for t, m in types.items() if m in wanted and t not in exclude)
    if len(found) > 1:
        raise bag_error(
            bag, None, None, f"one topic of type {' or '.join(sorted(wanted))} for {role} (name one)", ", ".join(found)
        )
    return found[0] if found else None


def read_topic(reader, topic: str) -> TopicMessages:
    """Every message of ``topic``, deserialized, in bag order (each failure names its message index)."""
    connections = [c for c in reader.connections if c.topic == topic]
    bag = bag_location(reader.paths[0])
    msgtype = connections[0].msgtype
    receive, header, messages = [], [], []
    index = 0
    try:
        for connection, stamp, raw in reader.messages(connections=connections):
            try:
                message = reader.deserialize(raw, connection.msgtype)
            except Exception as exc:
                raise bag_error(bag, topic, index, f"a {msgtype} message", f"{type(exc).__name__}: {exc}") from None
            receive.append(stamp)
            header.append(header_ns(message))
            messages.append(message)
            index += 1
    except DataFormatError:
        raise
    except Exception as exc:  # a truncated chunk or a damaged record ends the topic early
        raise bag_error(bag, topic, index, "a readable message record", f"{type(exc).__name__}: {exc}") from None
    has_header = all(h is not None for h in header)
    return TopicMessages(
        str(bag),
        topic,
        msgtype,
        np.asarray(receive, dtype=np.int64),
        np.asarray(header, dtype=np.int64) if has_header else None,
        messages,
    )


def header_ns(message) -> int | None:
    """The ``header.stamp`` of a message in nanoseconds (None without a header; a TFMessage: its first transform's)."""
    header = getattr(message, "header", None)
    if header is None and getattr(message, "transforms", None):
        header = message.transforms[0].header
    if header is None:
        return None
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)
