"""QoS profiles, type hashes and ``metadata.yaml`` of rosbag2 bags, shared by writer and readers.

rosbag2 keeps the QoS profiles its publishers offered for every topic twice: as YAML in the
``offered_qos_profiles`` metadata of the topic's MCAP channel and in ``metadata.yaml``; replay
(:mod:`wildfire_ros.bag_play`) publishes with them. :class:`QosSummary` keeps what matters for
matching and replay, and converts from and to rosbags' full profiles. Also here: the RIHS01
``type_description_hash`` Jazzy writes for every topic, and the ``custom_data`` keys we add to
``metadata.yaml`` — rosbags' reader does not expose that map, so :func:`read_custom_data`
parses the file itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from io import StringIO
from typing import TYPE_CHECKING, Any

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from ruamel.yaml import YAML

from wildfire_msgs_py.types import normalize_type_name, typestore

if TYPE_CHECKING:
    from pathlib import Path

_INFINITE = QosTime(0x7FFFFFFF, 0xFFFFFFFF)

#: Keys of ``custom_data`` in ``metadata.yaml`` (rosbag2's free-form map).
PRESET_KEY = "wildfire.compression_preset"
TIME_SOURCE_KEY = "wildfire.time_source"
SENSOR_KEY = "wildfire.sensor"
"""The aircraft's sensor and pixel error of a recorded run, e.g. ``camera,0.1``."""
WIND_FILTER_KEY = "wildfire.wind_filter"
"""``true`` when the recorded run's filtered belief took a wind filter's estimate."""


@dataclass(frozen=True)
class QosSummary:
    """The QoS policies of an offered profile that matter for matching and replay."""

    reliable: bool
    transient_local: bool
    depth: int


def rosbags_qos(profile: QosSummary) -> Qos:
    """A rosbags QoS profile (for ``metadata.yaml``) of a summary."""
    return Qos(
        QosHistory.KEEP_LAST,
        profile.depth,
        QosReliability.RELIABLE if profile.reliable else QosReliability.BEST_EFFORT,
        QosDurability.TRANSIENT_LOCAL if profile.transient_local else QosDurability.VOLATILE,
        _INFINITE,
        _INFINITE,
        QosLiveliness.AUTOMATIC,
        _INFINITE,
        False,
    )


def qos_summary(profile: Qos) -> QosSummary:
    """The summary of a rosbags QoS profile read from a bag."""
    return QosSummary(
        reliable=profile.reliability != QosReliability.BEST_EFFORT,
        transient_local=profile.durability == QosDurability.TRANSIENT_LOCAL,
        depth=int(profile.depth),
    )


def _yaml() -> YAML:
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    return yaml


def dump_yaml(data: Any) -> str:
    """``data`` as block-style YAML, as ``metadata.yaml`` and the MCAP metadata hold it."""
    stream = StringIO()
    _yaml().dump(data, stream)
    return stream.getvalue()


def parse_offered_qos(text: str) -> list[QosSummary]:
    """Offered QoS profiles of an MCAP channel's ``offered_qos_profiles`` (YAML) metadata."""
    try:
        profiles = _yaml().load(text) or []
        return [
            QosSummary(
                reliable=str(p.get("reliability", "reliable")).lower() != "best_effort",
                transient_local=str(p.get("durability", "volatile")).lower() == "transient_local",
                depth=int(p.get("depth", 0) or 0),
            )
            for p in profiles
            if isinstance(p, dict)
        ]
    except Exception:  # foreign metadata: a bag without QoS rather than no bag
        return []


def type_hash(type_name: str) -> str:
    """RIHS01 hash of a Jazzy type (as ``ros2 topic info -v`` shows it), or empty."""
    try:
        return typestore().hash_rihs01(normalize_type_name(type_name))
    except Exception:  # a type the store cannot describe: rosbag2 writes "" too
        return ""


def read_custom_data(path: Path) -> dict[str, str]:
    """``custom_data`` of a bag's ``metadata.yaml`` (rosbags' reader does not expose it)."""
    information = _yaml().load((path / "metadata.yaml").read_text(encoding="utf-8"))
    custom = (information.get("rosbag2_bagfile_information") or {}).get("custom_data") or {}
    return {str(k): str(v) for k, v in custom.items()}


__all__ = [
    "PRESET_KEY",
    "SENSOR_KEY",
    "TIME_SOURCE_KEY",
    "QosSummary",
    "dump_yaml",
    "parse_offered_qos",
    "qos_summary",
    "read_custom_data",
    "rosbags_qos",
    "type_hash",
]
