"""Interface package: topic contract, numpy<->message codecs, ROS 2 runtime binding (rclpy or Cyclone DDS)."""
