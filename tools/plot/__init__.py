"""``shoal plot``: the paper's figures from a run's log."""
