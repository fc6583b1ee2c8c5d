"""ROS 2 robots driven by a run over rmw_zenoh (``--robots ros2``; docs/ros2.md), with no ROS
install: rmw.py is the wire, node.py a node on it, config.py where a run's robots are,
bridge.py the robots as the world's plant, fleet.py the simulated robots of ``shoal robots``.
(A run as a ROS 2 bag: tools/rosbag/.)
"""
