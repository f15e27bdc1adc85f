"""Interface package of the wildfire system.

* :mod:`wildfire_msgs_py.contract` — topic names, types and QoS;
* :mod:`wildfire_msgs_py.codecs` — numpy arrays <-> ROS 2 messages;
* :mod:`wildfire_msgs_py.runtime` — rclpy, or the Cyclone DDS backend :mod:`wildfire_msgs_py.dds`;
* :mod:`wildfire_msgs_py.bag` — rosbag2 (MCAP) recording and reading;
* :mod:`wildfire_msgs_py.errors` — user-facing error classes.
"""
