"""One agent: the formation law, the collision-course flag Ω, the evasive offset, σ consensus."""
