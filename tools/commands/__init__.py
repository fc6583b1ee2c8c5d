"""The ``shoal`` command's verbs, one module each, and what they share."""
