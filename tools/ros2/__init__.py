"""ROS 2 (docs/ros2.md), with no ROS install; the ``rosbags`` package (``pip install
'shoal[ros2]'``) serialises the messages.

A run as a ROS 2 bag (``shoal export F.mcap --ros2 DIR``): metrics.py computes the numbers
(numpy, no ROS); msgs.py turns tick records into ROS messages; bag.py writes the rosbag2
directory.

ROS 2 robots driven by a run over rmw_zenoh (``--robots ros2``): rmw.py is the wire, node.py a
node on it, config.py where a run's robots are, bridge.py the robots as the world's plant,
fleet.py the simulated robots of ``shoal robots``.
"""
