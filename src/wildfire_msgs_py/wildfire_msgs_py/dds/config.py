"""Cyclone DDS network configuration guard: loopback only unless the user opts in.

Cyclone's built-in default multicasts discovery on every interface, which this project never
allows. Before the first participant is created, :func:`ensure_network_config` installs the
loopback configuration (the same settings as ``config/cyclonedds_loopback.xml``) whenever
``CYCLONEDDS_URI`` is unset or empty. Users who want several hosts set ``CYCLONEDDS_URI`` to a
file such as ``config/cyclonedds_multihost.xml`` themselves.
"""

from __future__ import annotations

import os

from wildfire_msgs_py.errors import BackendError

#: Inline form of ``config/cyclonedds_loopback.xml`` (Cyclone accepts XML in CYCLONEDDS_URI).
LOOPBACK_CONFIG_XML = (
    '<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="any">'
    '<General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General>"
    "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>"
    '<Peers><Peer address="127.0.0.1"/></Peers></Discovery>'
    "</Domain></CycloneDDS>"
)


def ensure_network_config() -> str:
    """Install the loopback configuration unless the user chose one; return what is in force."""
    uri = os.environ.get("CYCLONEDDS_URI", "").strip()
    if not uri:
        os.environ["CYCLONEDDS_URI"] = LOOPBACK_CONFIG_XML
        return LOOPBACK_CONFIG_XML
    return uri


def ros_domain_id() -> int:
    """``ROS_DOMAIN_ID`` (default 0), checked to lie in 0..232 like ROS 2 requires."""
    text = os.environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    try:
        domain = int(text)
    except ValueError:
        raise BackendError(f"ROS_DOMAIN_ID={text!r}: expected a whole number 0..232") from None
    if not 0 <= domain <= 232:
        raise BackendError(f"ROS_DOMAIN_ID={text!r}: expected a whole number 0..232")
    return domain


__all__ = ["LOOPBACK_CONFIG_XML", "ensure_network_config", "ros_domain_id"]
