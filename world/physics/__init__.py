"""A physics plant: MuJoCo moves robots with mass (docs/physics.md). Needs the ``physics`` extra."""
