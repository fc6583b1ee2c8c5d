"""Foxglove's published JSON schemas that the views embed (data files; README.md says where
they come from). A package only so that it ships like world/scenarios and reads through
importlib.resources."""
