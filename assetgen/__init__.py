"""Procedural peg-in-hole assembly modules with an exact, verified clearance."""

GENERATOR_VERSION = "0.2.0"
"""Bumped whenever generated files or records change. 0.2.0: the collision record holds
separating-plane lower bounds (`clearance_lower_bound_m`, `insertion_lower_bound_m`,
`pieces_measured_with_fcl`) instead of one FCL query's distances; piece coordinates are
stored with one sign of zero. The pieces' geometry is unchanged."""
