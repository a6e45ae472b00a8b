"""Dev studies of the observation grouping: its knobs on real logs, loop closure, the
association and noise variants, and the figures of its docs."""
