"""A run as a ROS 2 bag (``shoal export F.mcap --ros2 DIR``; docs/ros2.md), with no ROS
install; the ``rosbags`` package (``pip install 'shoal[ros2]'``) serialises the messages.

metrics.py computes the numbers (numpy, no ROS); msgs.py turns tick records into ROS messages;
writer.py writes the rosbag2 directory.
"""
