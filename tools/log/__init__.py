"""A run's MCAP log: the logger, writing, reading, salvaging and replaying it."""
