"""Procedural peg-in-hole assembly modules with an exact, verified clearance."""

GENERATOR_VERSION = "0.1.0"
