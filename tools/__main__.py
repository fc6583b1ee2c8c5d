"""``python -m tools``: the same as the ``shoal`` console script (used to spawn children)."""

from shoal.tools.procs.swarm import adopt_supervisor

adopt_supervisor()  # before anything slow: a child of shoal run dies with it, even while starting

from shoal.tools.cli import main  # noqa: E402

main()
