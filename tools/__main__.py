"""``python -m tools``: the same as the ``shoal`` console script (used to spawn children)."""

from tools.cli import main

main()
