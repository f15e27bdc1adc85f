"""Reading bags: :func:`open_reader` and :func:`read_messages`, over rosbags' rosbag2 reader.

:func:`read_messages` yields typed messages in time order (rosbags dataclasses with numpy
arrays, deserialized with the ROS 2 Jazzy type store; the codecs of
:mod:`wildfire_msgs_py.codecs` accept them) for offline training, or the raw CDR bytes.
Every failure to open or read a bag is a :class:`~wildfire_msgs_py.errors.BagError` naming the
file and what is wrong; a missing ``metadata.yaml`` or a truncated ``.mcap`` file points to
``wildfire bag reindex``, which recovers it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from rosbags.rosbag2 import Reader, ReaderError

from wildfire_msgs_py.errors import BagError
from wildfire_msgs_py.types import typestore

if TYPE_CHECKING:
    from collections.abc import Iterable, Iterator


class BagMessage(NamedTuple):
    """One recorded message."""

    topic: str
    type: str
    """ROS type name, ``pkg/msg/Type``."""
    time_ns: int
    """Log time in nanoseconds: receive time (system clock or sim time)."""
    message: Any
    """Deserialized message (rosbags dataclass), or CDR bytes when read with ``raw=True``."""


def mcap_files(path: Path) -> list[Path]:
    """The ``.mcap`` files of a bag directory, sorted by name."""
    return sorted(path.glob("*.mcap"))


def open_reader(bag_dir: str | Path) -> Reader:
    """An open rosbags reader; :class:`BagError` names the file and what is wrong."""
    path = Path(bag_dir)
    if not path.exists():
        raise BagError(f"bag {path}: no such directory")
    if path.is_file():
        raise BagError(f"bag {path}: expected a rosbag2 directory, got a file")
    if not (path / "metadata.yaml").is_file():
        files = mcap_files(path)
        if files:
            raise BagError(
                f"bag {path}: no metadata.yaml next to {files[0].name} (recording not "
                f"finalized?); `wildfire bag reindex {path}` recovers it"
            )
        raise BagError(f"bag {path}: expected a rosbag2 directory with metadata.yaml")
    try:
        reader = Reader(path)
    except (ReaderError, OSError, KeyError, ValueError, TypeError) as error:
        raise BagError(f"bag {path / 'metadata.yaml'}: unreadable or corrupt ({error})") from None
    try:
        reader.open()
    except (ReaderError, OSError, KeyError, ValueError, TypeError, IndexError) as error:
        names = ", ".join(p.name for p in mcap_files(path)) or "its .mcap file"
        raise BagError(
            f"bag {path}: {names} is truncated or corrupt ({error}); "
            f"`wildfire bag reindex {path}` recovers its complete chunks"
        ) from None
    return reader


def read_messages(
    bag_dir: str | Path, topics: Iterable[str] | None = None, *, raw: bool = False
) -> Iterator[BagMessage]:
    """Messages of a bag in time order, deserialized with the ROS 2 Jazzy type store."""
    reader = open_reader(bag_dir)
    store = typestore()
    wanted = None if topics is None else set(topics)
    try:
        connections = [c for c in reader.connections if wanted is None or c.topic in wanted]
        if wanted is not None:
            missing = wanted - {c.topic for c in connections}
            if missing:
                raise BagError(f"bag {bag_dir}: no topic {', '.join(sorted(missing))}")
        try:
            for connection, time_ns, data in reader.messages(connections=connections):
                message = data if raw else store.deserialize_cdr(data, connection.msgtype)
                yield BagMessage(connection.topic, connection.msgtype, time_ns, message)
        except (ReaderError, ValueError, IndexError, KeyError, OSError) as error:
            raise BagError(f"bag {bag_dir}: corrupt message data ({error})") from None
    finally:
        reader.close()


__all__ = ["BagMessage", "mcap_files", "open_reader", "read_messages"]
