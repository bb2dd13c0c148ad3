"""Procedural peg-in-hole assembly modules with an exact, verified clearance."""

GENERATOR_VERSION = "0.3.0"
"""Bumped whenever generated files or records change; CHANGELOG.md says what changed."""
