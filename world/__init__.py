"""The world: scenarios, kinematics, obstacle sensing and ground-truth metrics."""
