"""``shoal campaign``: random obstacle fields, run and judged by the thousand."""
