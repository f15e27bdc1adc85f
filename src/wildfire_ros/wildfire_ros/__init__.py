"""ROS 2 runtime of the wildfire system.

* :mod:`wildfire_ros.runtime` — rclpy, or our Cyclone DDS layer :mod:`wildfire_ros.dds`, behind
  one import surface for node code;
* :mod:`wildfire_ros.node_support` — parameters, contract endpoints and the node main loop;
* :mod:`wildfire_ros.network_defaults` — loopback-only DDS defaults, multi-host settings;
* :mod:`wildfire_ros.bag` — rosbag2 (MCAP) recording and reading, ``bag_play`` and
  ``bag_repair``.

It builds on the interface package :mod:`wildfire_msgs_py` (contract, codecs, message types);
nothing there imports from here.
"""
