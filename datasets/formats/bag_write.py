"""Writing ROS bags with ``rosbags``: ROS 1 ``.bag``, ROS 2 folders (sqlite3 or MCAP storage), bare ``.mcap``.

:class:`BagWriter` takes messages built by :func:`~.ros_messages.message` with its :attr:`BagWriter.typestore`
(ROS 1 Noetic types for a ``.bag``, ROS 2 Humble types otherwise) and a receive time in seconds per message.
The storage follows the path: ``*.bag`` → ROS 1; ``*.mcap`` → a bare MCAP file (written as a ROS 2 MCAP bag in a
temporary folder, then moved out: the file holds its schemas and opens in Foxglove on its own); any other path →
a ROS 2 bag folder, sqlite3 unless ``storage="mcap"``. The target must not exist.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Literal

__all__ = ["BagWriter"]


class BagWriter:
    """A context manager writing one bag (module docstring)."""

    def __init__(self, path: str | Path, storage: Literal["sqlite3", "mcap"] = "sqlite3"):
        from rosbags.typesys import Stores, get_typestore

        self.path = Path(path)
        if self.path.exists():
            raise FileExistsError(f"{self.path} exists; a bag is written to a new path")
        self.ros1 = self.path.suffix == ".bag"
        self.bare = self.path.suffix == ".mcap"
        self.storage = "mcap" if self.bare else storage
        self.typestore = get_typestore(Stores.ROS1_NOETIC if self.ros1 else Stores.ROS2_HUMBLE)
        if self.ros1:  # rosbags' Noetic store lacks tf2_msgs; its ROS 1 definition is one line
            from rosbags.typesys import get_types_from_msg

            self.typestore.register(
                get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage")
            )
        self._connections: dict[str, object] = {}
        self._tmp: Path | None = None

    def __enter__(self) -> BagWriter:
        if self.ros1:
            from rosbags.rosbag1 import Writer

            self._writer = Writer(self.path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            target = self.path
            if self.bare:
                self._tmp = Path(tempfile.mkdtemp(prefix="slamarena-mcap-"))
                target = self._tmp / "bag"
            plugin = StoragePlugin.MCAP if self.storage == "mcap" else StoragePlugin.SQLITE3
            self._writer = Writer(target, version=8, storage_plugin=plugin)
        self._writer.open()
        return self

    def write(self, topic: str, t: float, msg) -> None:
        """Append ``msg`` on ``topic`` with receive time ``t`` [s] (the topic's type is that of its first message)."""
        msgtype = msg.__msgtype__
        if topic not in self._connections:
            self._connections[topic] = self._writer.add_connection(topic, msgtype, typestore=self.typestore)
        data = self.typestore.serialize_ros1(msg, msgtype) if self.ros1 else self.typestore.serialize_cdr(msg, msgtype)
        self._writer.write(self._connections[topic], int(round(t * 1e9)), data)

    def __exit__(self, *exc) -> None:
        self._writer.close()
        if self._tmp is not None:
            try:
                if exc[0] is None:
                    shutil.move(str(next((self._tmp / "bag").glob("*.mcap"))), self.path)
            finally:
                shutil.rmtree(self._tmp, ignore_errors=True)
