"""ROS 2 bags through rosbags: written atomically, read with errors that name the bag and the topic.

BagWriter(path) writes MCAP storage: a path ending in .mcap becomes one MCAP file (what Foxglove opens
and `ros2 bag play` plays), any other path a rosbag2 directory (metadata.yaml and the .mcap file). The
bag is written into a temporary directory beside the path and moved into place only when complete:
an error or Ctrl-C (SIGINT) while writing leaves no half bag, and the file a path held before stays
as it was.

messages(path, topics) reads a bag (a directory or a bare .mcap file) message by message;
topics(path) lists its topics, types and counts; copy(path, writer) copies a bag into a BagWriter as it is.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Dict, Iterable, Iterator, Optional, Tuple

from . import types as t

# What ibvs.ros re-exports (and documents); the other names here are its own helpers.
__all__ = ["BagWriter", "topics", "messages"]


def _rosbags():
    try:
        import rosbags.rosbag2 as rosbag2
    except ImportError as e:
        raise ImportError(f"ROS 2 bags need rosbags: {t.ROS_INSTALL}") from e
    return rosbag2


class BagWriter:
    """A ROS 2 bag (MCAP storage) written atomically; use it as a context manager:

        with BagWriter("run.mcap") as bag:
            bag.write("/ibvs/cmd_twist", msg, stamp_ns)   # msg: a message of rosbags' typestore

    The bag appears at `path` when the block ends without an exception; on an exception (KeyboardInterrupt
    included) nothing is written there."""

    def __init__(self, path, typestore=None):
        rosbag2 = _rosbags()
        self.path = Path(path)
        parent = self.path.parent if str(self.path.parent) else Path(".")
        if not parent.is_dir():
            raise FileNotFoundError(f"record: directory {str(parent)!r} does not exist")
        if self.path.is_dir() and self.path.suffix == ".mcap":
            raise IsADirectoryError(f"record: {str(self.path)!r} is a directory; a .mcap path is written as one file")
        self.typestore = t.typestore() if typestore is None else typestore
        self._tmp = Path(tempfile.mkdtemp(prefix=f".{self.path.name}.partial-", dir=parent))
        self._bag = self._tmp / "bag"
        self._writer = rosbag2.Writer(self._bag, version=9, storage_plugin=rosbag2.StoragePlugin.MCAP)
        self._connections: Dict[str, object] = {}
        self.counts: Dict[str, int] = {}

    def __enter__(self) -> "BagWriter":
        try:
            self._writer.open()
        except BaseException:
            shutil.rmtree(self._tmp, ignore_errors=True)
            raise
        return self

    def write(self, topic: str, msg, stamp_ns: int) -> None:
        """Write msg (its type is msg.__msgtype__) on topic at stamp_ns (the bag's log time)."""
        msgtype = msg.__msgtype__
        self.write_raw(topic, msgtype, self.typestore.serialize_cdr(msg, msgtype), stamp_ns)

    def write_raw(self, topic: str, msgtype: str, data, stamp_ns: int, typestore=None) -> None:
        """Write a message already serialised (CDR) on topic at stamp_ns; typestore: where its type is defined
        (default this writer's), e.g. the typestore of the bag it was read from (its own message types)."""
        conn = self._connections.get(topic)
        if conn is None:
            conn = self._writer.add_connection(topic, msgtype, typestore=typestore or self.typestore)
            self._connections[topic] = conn
        elif conn.msgtype != msgtype:
            raise ValueError(f"record: topic {topic} carries {conn.msgtype}, not {msgtype}")
        self._writer.write(conn, int(stamp_ns), data)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def __exit__(self, kind, value, tb) -> None:
        try:
            self._writer.close()
            if kind is None:
                self._move_into_place()
        finally:
            shutil.rmtree(self._tmp, ignore_errors=True)

    def _move_into_place(self) -> None:
        if self.path.suffix == ".mcap":
            (mcap,) = self._bag.glob("*.mcap")
            os.replace(mcap, self.path)  # atomic: the old file, or the new one, never half of one
            return
        if self.path.exists():  # a directory bag: the old one goes only once the new one is complete
            old = self._tmp / "old"
            os.replace(self.path, old)
        os.replace(self._bag, self.path)


def _reader(path):
    """An open rosbags AnyReader of a bag directory or an .mcap file, or a clear error naming the bag."""
    _rosbags()
    from rosbags.highlevel import AnyReader

    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"bag {str(p)!r} does not exist")
    reader = AnyReader([p], default_typestore=t.typestore())
    try:
        reader.open()
    except Exception as e:  # rosbags raises its own errors for a truncated file or a bad metadata.yaml
        raise ValueError(f"bag {str(p)!r} cannot be read ({type(e).__name__}: {e}): truncated, or not a ROS 2 "
                         f"bag (a rosbag2 directory or an .mcap file)") from None
    return reader


def copy(path, writer: BagWriter) -> None:
    """Every message of the bag at path into writer as it is (serialised bytes, with its own message types:
    a real robot's bag may use types rosbags does not know)."""
    reader = _reader(path)
    try:
        for conn, ns, raw in reader.messages():
            writer.write_raw(conn.topic, conn.msgtype, raw, ns, reader.typestore)
    except (KeyboardInterrupt, GeneratorExit):
        raise
    except Exception as e:
        raise ValueError(f"bag {str(path)!r}: reading failed ({type(e).__name__}: {e}): truncated?") from None
    finally:
        reader.close()


def topics(path) -> Dict[str, Tuple[str, int]]:
    """{topic: (message type, message count)} of a bag."""
    reader = _reader(path)
    try:
        out: Dict[str, Tuple[str, int]] = {}
        for c in reader.connections:
            msgtype, n = out.get(c.topic, (c.msgtype, 0))
            out[c.topic] = (msgtype, n + c.msgcount)
        return out
    finally:
        reader.close()


def messages(path, topics: Optional[Iterable[str]] = None) -> Iterator[Tuple[str, int, object]]:
    """(topic, log time ns, message) of a bag in log-time order, for the given topics (default all).
    A topic the bag lacks is a ValueError naming it and listing the bag's; a bag cut short while being
    read (a truncated file) is a ValueError naming the bag."""
    reader = _reader(path)
    try:
        have = sorted({c.topic for c in reader.connections})
        wanted = None if topics is None else list(topics)
        for name in wanted or ():
            if name not in have:
                raise ValueError(f"bag {str(path)!r} has no topic {name!r} (its topics: {', '.join(have)})")
        conns = [c for c in reader.connections if wanted is None or c.topic in wanted]
        try:
            for conn, ns, raw in reader.messages(connections=conns):
                yield conn.topic, ns, reader.deserialize(raw, conn.msgtype)
        except (KeyboardInterrupt, GeneratorExit):
            raise
        except Exception as e:
            raise ValueError(f"bag {str(path)!r}: reading failed ({type(e).__name__}: {e}): truncated?") from None
    finally:
        reader.close()
