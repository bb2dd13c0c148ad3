"""Procedural peg-in-hole assembly modules with an exact, verified clearance."""

GENERATOR_VERSION = "0.2.1"
"""Bumped whenever generated files or records change. 0.2.1: the module checks measure the
convex peg and its sweeps with GJK (fcl.Convex) against the module's triangles: distances
within 2.1 nm of 0.2.0's triangle-triangle ones; the pieces' total volume is summed in one
pass. Files other than module.json are unchanged. 0.2.0: the collision record holds
separating-plane lower bounds (`clearance_lower_bound_m`, `insertion_lower_bound_m`,
`pieces_measured_with_fcl`) instead of one FCL query's distances; piece coordinates are
stored with one sign of zero. The pieces' geometry is unchanged."""
