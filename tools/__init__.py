"""Command line, reference simulator, logger and reports."""
