"""Procedural peg-in-hole assembly modules with an exact, verified clearance.

The stages, in data-flow order: `params` (Table I sampler, one module's parameters) ->
`geometry` (solids and frames) -> `checks` (the written STL files: closed, genus 0, exact
clearance, free insertion) -> `collision` (convex pieces, re-checked as written) ->
`formats` (3MF, USD, MJCF) -> `dataset` (specs, resumable parallel generation, reading,
re-checking). `core` holds the numpy-only pieces every stage, the simulator and the preview
share (meshes, STL, frames, the MuJoCo configuration, atomic files, timing); `physics` runs
the MJCF physics checks of written modules; `bench` times the whole pipeline.
"""

GENERATOR_VERSION = "0.8.0"
"""Bumped whenever generated files or records change; CHANGELOG.md says what changed."""
