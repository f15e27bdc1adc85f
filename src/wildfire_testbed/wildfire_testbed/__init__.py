"""Test and fault tools: the real system on several virtual hosts and under hostile conditions.

* :mod:`~wildfire_testbed.hosts` — virtual hosts: one network namespace per host, joined by
  a bridge (``wildfire run --hosts``, the multi-host tests);
* :mod:`~wildfire_testbed.netfaults` — link faults: netem loss, delay and rate, and timed
  partitions (``--netem``, ``--partition``);
* :mod:`~wildfire_testbed.netem_switch` — the user-space switch that applies netem between
  hosts where the kernel bridge cannot;
* :mod:`~wildfire_testbed.wire_fuzzer` — a hostile participant that floods every topic with
  malformed, replayed and far-future messages.
"""
