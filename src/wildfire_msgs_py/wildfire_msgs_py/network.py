"""Keep every DDS participant on this machine unless the user chose otherwise.

Both DDS implementations default to discovery by multicast on every interface, which this
project never does on its own. :func:`apply_local_network_defaults` fills the environment, before
the first participant exists, with loopback-only settings for whichever middleware runs:

* **Cyclone DDS** (our DDS backend, or rmw_cyclonedds_cpp): ``CYCLONEDDS_URI`` gets the inline
  form of ``config/cyclonedds_loopback.xml`` when it is unset or empty.
* **Fast DDS** (the real rclpy's rmw_fastrtps_cpp): when neither ``FASTRTPS_DEFAULT_PROFILES_FILE``
  nor ``FASTDDS_DEFAULT_PROFILES_FILE`` is set, and the user asked for no wider discovery
  (``ROS_AUTOMATIC_DISCOVERY_RANGE`` unset or ``LOCALHOST``, ``ROS_STATIC_PEERS`` unset),
  ``FASTRTPS_DEFAULT_PROFILES_FILE`` points at ``config/fastdds_loopback.xml`` (127.0.0.1 and
  shared memory only, unicast discovery) and ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is ``LOCALHOST``.

A variable the user set is never touched, so several hosts are an explicit opt-in (see
``docs/deployment.md``). ``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET`` or ``ROS_STATIC_PEERS`` is such
an opt-in for Fast DDS: the loopback profile would whitelist 127.0.0.1 only and so silently
defeat it. The runtime calls this when it is imported; the launcher calls it on
the environment of every child it starts.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping
from pathlib import Path

#: Inline form of ``config/cyclonedds_loopback.xml`` (Cyclone accepts XML in CYCLONEDDS_URI).
CYCLONEDDS_LOOPBACK_XML = (
    '<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="any">'
    '<General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>"
    '<Peers><Peer address="127.0.0.1"/></Peers></Discovery>'
    "</Domain></CycloneDDS>"
)

#: The shipped Fast DDS profile (``config/fastdds_loopback.xml``, installed with this package).
FASTDDS_LOOPBACK_PROFILE = Path(__file__).resolve().parent / "data" / "fastdds_loopback.xml"

FASTDDS_PROFILE_VARIABLES = ("FASTRTPS_DEFAULT_PROFILES_FILE", "FASTDDS_DEFAULT_PROFILES_FILE")


def apply_local_network_defaults(
    env: MutableMapping[str, str] | None = None,
) -> dict[str, str]:
    """Set the loopback defaults in ``env`` (default ``os.environ``) where the user set nothing.

    Returns the variables it set, by name.
    """
    env = os.environ if env is None else env
    applied: dict[str, str] = {}
    if not env.get("CYCLONEDDS_URI", "").strip():
        applied["CYCLONEDDS_URI"] = CYCLONEDDS_LOOPBACK_XML
    discovery_range = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip()
    # SUBNET / SYSTEM_DEFAULT / OFF, or static peers, are the user's own discovery choice; the
    # loopback profile (UDP on 127.0.0.1 only) would make it unreachable without a word.
    wider_discovery = discovery_range.upper() not in ("", "LOCALHOST") or bool(
        env.get("ROS_STATIC_PEERS", "").strip()
    )
    user_profile = any(env.get(name, "").strip() for name in FASTDDS_PROFILE_VARIABLES)
    if not user_profile and not wider_discovery:
        applied["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(FASTDDS_LOOPBACK_PROFILE)
        if not discovery_range:
            applied["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.update(applied)
    return applied


__all__ = [
    "CYCLONEDDS_LOOPBACK_XML",
    "FASTDDS_LOOPBACK_PROFILE",
    "FASTDDS_PROFILE_VARIABLES",
    "apply_local_network_defaults",
]
