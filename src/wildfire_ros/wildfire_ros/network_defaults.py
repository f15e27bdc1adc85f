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

For a system spread over several hosts whose addresses are known, :func:`host_network_environment`
gives the variables of one host: both middlewares on that host's address only, multicast off,
unicast discovery to the listed hosts (the generated twins of ``config/cyclonedds_multihost.xml``
and ``config/fastdds_multihost.xml``). ``wildfire run --hosts K`` sets them on every process; being
set, they are the user's choice to :func:`apply_local_network_defaults`.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping, Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

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


#: Variables that would pull a host's participants off its explicit configuration: another
#: profile file (Fast DDS 3 reads ``FASTDDS_``), extra peers, localhost-only or a discovery server.
CONFLICTING_HOST_VARIABLES = (
    "FASTDDS_DEFAULT_PROFILES_FILE",
    "ROS_STATIC_PEERS",
    "ROS_LOCALHOST_ONLY",
    "ROS_DISCOVERY_SERVER",
)


HOST_LEASE_S = 60
"""Participant lease of the hosts' participants, both middlewares (defaults: Cyclone 10 s, Fast
DDS 20 s). A network partition shorter than the lease leaves every match in place, so reliable
writers retransmit what the cut lost once it heals (a lockstep barrier resumes); a longer one
ends the matches and the hosts discover each other afresh (see :data:`HOST_SPDP_INTERVAL_S`)."""
HOST_FASTDDS_MAX_MESSAGE_BYTES = 1400
"""Fast DDS's UDP datagrams on the hosts: one Ethernet frame each. By default it sends up to
64 kB per datagram and leaves the splitting to IP, so one lost frame of a 40 kB belief loses the
whole datagram and its repair resends all of it; at 2 % frame loss the shared belief seen by the
run monitor fell to an IoU of 0.22 to 0.29 (0.70 without loss). With datagrams that fit a frame
it fragments the sample itself and repairs only the lost fragments, as Cyclone does (1344 B
fragments by default): IoU 0.70 under the same loss."""
HOST_SPDP_INTERVAL_S = 3
"""Cyclone's participant announcements to the peers (default 30 s, Fast DDS's is 3 s): how soon
two hosts find each other again after a partition longer than the lease."""


def cyclonedds_hosts_xml(address: str, peers: Sequence[str]) -> str:
    """Inline ``CYCLONEDDS_URI`` of one host: its interface only, multicast off, these peers.

    The generated form of ``config/cyclonedds_multihost.xml``, plus partition tolerance:
    :data:`HOST_LEASE_S`, :data:`HOST_SPDP_INTERVAL_S`, and peers' addresses kept for good
    (``DiscoveredLocatorPruneDelay``; by default Cyclone forgets the address of a participant
    whose lease expired after 60 s and then never announces itself there again, so a host cut
    off for longer would stay cut off after the heal).
    """
    peer_list = "".join(f"<Peer address={quoteattr(peer)}/>" for peer in peers)
    return (
        '<CycloneDDS xmlns="https://cdds.io/config"><Domain Id="any">'
        f"<General><Interfaces><NetworkInterface address={quoteattr(address)}/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast></General>"
        "<Discovery><ParticipantIndex>auto</ParticipantIndex>"
        "<MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>"
        f"<LeaseDuration>{HOST_LEASE_S} s</LeaseDuration>"
        f"<SPDPInterval>{HOST_SPDP_INTERVAL_S} s</SPDPInterval>"
        "<DiscoveredLocatorPruneDelay>inf</DiscoveredLocatorPruneDelay>"
        f"<Peers>{peer_list}</Peers></Discovery>"
        "</Domain></CycloneDDS>"
    )


def _udp_locator(address: str) -> str:
    return f"<locator><udpv4><address>{address}</address></udpv4></locator>"


def fastdds_hosts_profile(address: str, peers: Sequence[str]) -> str:
    """Fast DDS profile XML of one host: UDPv4 on its address only, unicast discovery to peers.

    The generated form of ``config/fastdds_multihost.xml`` without its shared-memory transport:
    the virtual hosts of ``wildfire run --hosts`` share one ``/dev/shm``, through which they could
    reach each other around the network under test. Participants of one host talk over UDP to
    their own address (the kernel delivers that locally). The lease is :data:`HOST_LEASE_S`
    (Fast DDS announces every 3 s and never forgets its initial peers); datagrams are at most
    :data:`HOST_FASTDDS_MAX_MESSAGE_BYTES`.
    """
    initial_peers = "".join(_udp_locator(peer) for peer in peers)
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>wildfire_udp_host</transport_id>
        <type>UDPv4</type>
        <maxMessageSize>{HOST_FASTDDS_MAX_MESSAGE_BYTES}</maxMessageSize>
        <maxInitialPeersRange>32</maxInitialPeersRange>
        <interfaceWhiteList><address>{address}</address></interfaceWhiteList>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="wildfire_host" is_default_profile="true">
      <rtps>
        <useBuiltinTransports>false</useBuiltinTransports>
        <userTransports><transport_id>wildfire_udp_host</transport_id></userTransports>
        <defaultUnicastLocatorList>{_udp_locator(address)}</defaultUnicastLocatorList>
        <builtin>
          <discovery_config>
            <leaseDuration><sec>{HOST_LEASE_S}</sec></leaseDuration>
          </discovery_config>
          <metatrafficUnicastLocatorList>{_udp_locator(address)}</metatrafficUnicastLocatorList>
          <initialPeersList>{initial_peers}</initialPeersList>
        </builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
"""


def host_network_environment(
    address: str, peers: Sequence[str], profile_dir: Path, name: str
) -> dict[str, str]:
    """The DDS variables of one host (both middlewares); writes its Fast DDS profile.

    ``profile_dir/fastdds-<name>.xml`` receives the profile. ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is
    ``SYSTEM_DEFAULT`` so that rmw_fastrtps applies the profile as written (with ``SUBNET`` it adds
    the multicast group to the initial peers, with ``LOCALHOST`` a UDP transport on every
    interface). Remove :data:`CONFLICTING_HOST_VARIABLES` from an environment these go into.
    """
    profile = profile_dir / f"fastdds-{name}.xml"
    profile.write_text(fastdds_hosts_profile(address, peers))
    return {
        "CYCLONEDDS_URI": cyclonedds_hosts_xml(address, peers),
        "FASTRTPS_DEFAULT_PROFILES_FILE": str(profile),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "SYSTEM_DEFAULT",
    }


__all__ = [
    "CONFLICTING_HOST_VARIABLES",
    "CYCLONEDDS_LOOPBACK_XML",
    "FASTDDS_LOOPBACK_PROFILE",
    "FASTDDS_PROFILE_VARIABLES",
    "HOST_FASTDDS_MAX_MESSAGE_BYTES",
    "HOST_LEASE_S",
    "HOST_SPDP_INTERVAL_S",
    "apply_local_network_defaults",
    "cyclonedds_hosts_xml",
    "fastdds_hosts_profile",
    "host_network_environment",
]
