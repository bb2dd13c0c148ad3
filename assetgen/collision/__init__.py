"""Stage 4, collision pieces: the module as a union of convex pieces for MuJoCo, which
collides a mesh as its convex hull. The exact decomposition for convex holes, CoACD for
non-convex ones, and the separating-plane re-check that proves each piece as written keeps
its distance to the seated peg and to its insertion path."""
