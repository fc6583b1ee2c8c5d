"""Views of a run for Foxglove, written into an MCAP file beside its raw log."""
