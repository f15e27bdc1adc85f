"""rosbag2 recording and reading: a directory with ``metadata.yaml`` and one ``.mcap`` file.

Bags are written as ROS 2 Jazzy's ``ros2 bag record -s mcap`` writes them: ``metadata.yaml``
version 9 with ``ros_distro: jazzy``, the RIHS01 ``type_description_hash`` of every topic
(computed from the type description as Jazzy does, by the rosbags type store) and the offered
QoS profiles of its publishers; MCAP channels with ``offered_qos_profiles`` and
``topic_type_hash`` metadata, ``ros2msg`` schemas, CDR payloads and per-channel sequence
numbers. Chunks are zstd-compressed (:mod:`wildfire_ros.mcap_writer`, preset
``zstd_fast``), so ``ros2 bag``, Foxglove, ``mcap`` and rosbags read them unchanged.

Split as rosbags splits its ``rosbag2`` package; every name is re-exported here, so import
from ``wildfire_ros.bag``. The modules import each other directly, never this package.

* :mod:`~wildfire_ros.bag.writer` — :class:`BagWriter`: add topics and raw CDR messages;
  ``close()`` finalizes the file.
* :mod:`~wildfire_ros.bag.recorder` — :class:`BagRecorder`: a node that subscribes (raw) to
  given topics or to every topic, including topics that appear later, and writes each
  message; finalize with ``close()``. Recording every topic leaves out :data:`BULKY_TOPICS`
  unless asked for. Log times are receive times on the system clock or on sim time.
* :mod:`~wildfire_ros.bag.reader` — :func:`read_messages`: typed messages in time order
  (rosbags dataclasses with numpy arrays; the codecs of :mod:`wildfire_msgs_py.codecs` accept
  them) for offline training; :func:`open_reader`.
* :mod:`~wildfire_ros.bag.info` — :func:`bag_info`: what ``ros2 bag info`` prints, with
  compression and per-topic sizes.
* :mod:`~wildfire_ros.bag.metadata` — offered QoS profiles (:class:`QosSummary`), RIHS01
  type hashes and the ``custom_data`` of ``metadata.yaml``.

Playing and repairing bags live beside this package, in :mod:`wildfire_ros.bag_play` and
:mod:`wildfire_ros.bag_repair`.
"""

from wildfire_ros.bag.info import BagInfo, TopicSummary, bag_info
from wildfire_ros.bag.metadata import (
    PRESET_KEY,
    SENSOR_KEY,
    TIME_SOURCE_KEY,
    WIND_FILTER_KEY,
    QosSummary,
    parse_offered_qos,
    qos_summary,
    read_custom_data,
    rosbags_qos,
    type_hash,
)
from wildfire_ros.bag.reader import BagMessage, open_reader, read_messages
from wildfire_ros.bag.recorder import BULKY_TOPICS, BagRecorder, offered_qos
from wildfire_ros.bag.writer import BagWriter

__all__ = [
    "BULKY_TOPICS",
    "PRESET_KEY",
    "SENSOR_KEY",
    "TIME_SOURCE_KEY",
    "WIND_FILTER_KEY",
    "BagInfo",
    "BagMessage",
    "BagRecorder",
    "BagWriter",
    "QosSummary",
    "TopicSummary",
    "bag_info",
    "offered_qos",
    "open_reader",
    "parse_offered_qos",
    "qos_summary",
    "read_custom_data",
    "read_messages",
    "rosbags_qos",
    "type_hash",
]
