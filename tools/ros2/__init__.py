"""A run as a ROS 2 bag (``shoal export F.mcap --ros2 DIR``, docs/ros2.md): standard message
types, CDR in MCAP, written with the ``rosbags`` package (``pip install 'shoal[ros2]'``).

metrics.py computes the numbers (numpy, no ROS); msgs.py turns tick records into ROS messages
(needs rosbags); bag.py writes the rosbag2 directory.
"""
