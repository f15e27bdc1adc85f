"""Interface package of the wildfire system.

* :mod:`wildfire_msgs_py.contract` — topic names, types and QoS;
* :mod:`wildfire_msgs_py.codecs` and :mod:`wildfire_msgs_py.system_codecs` — numpy arrays <->
  ROS 2 messages;
* :mod:`wildfire_msgs_py.wire_checks` and :mod:`wildfire_msgs_py.input_guard` — validation of
  what arrives from the wire;
* :mod:`wildfire_msgs_py.messages` — the message classes of the runtime in use (rclpy's, or
  those of :mod:`wildfire_msgs_py.types` for our Cyclone DDS layer);
* :mod:`wildfire_msgs_py.errors` — user-facing error classes;
* :mod:`wildfire_msgs_py.stop_signals` — SIGINT and SIGTERM as a clean stop, recognised
  wherever they land.

The runtime that publishes these messages is the package :mod:`wildfire_ros`.
"""
