"""A policy that sees: a student with a depth camera and its own pose, distilled from a
privileged teacher (one that observes the hole's pose) by DAgger. docs/cameras.md."""
