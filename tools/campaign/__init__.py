"""``shoal campaign`` and ``shoal scenarios new``: scenarios drawn by the thousand (random
obstacle fields, hard fields, formations of a shape), run and judged."""
