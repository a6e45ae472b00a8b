"""Dev studies of the manifold clustering: diagnoses of its failures, bounds of what
image and laser features allow, and the sweeps and kernels behind its defaults."""
