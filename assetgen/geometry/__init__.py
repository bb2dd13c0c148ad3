"""Stage 2, geometry: module parameters to solids and frames. The convex peg, the hole as the
peg's face planes moved out by exactly the clearance (mitred), the plate and sleeve minus the
hole with manifold3d, the task frames (entrance, bottom, design pose) and the peg's mass
properties. Pure functions: parameters in, meshes and frames out."""
