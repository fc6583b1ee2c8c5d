"""``shoal bench``: performance figures next to the floor they are held against."""
