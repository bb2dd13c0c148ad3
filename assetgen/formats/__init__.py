"""Stage 5, files: 3MF for printing, USD with physics for Isaac Sim, MJCF for MuJoCo, and the
registry of simulation formats (`registry.EXPORTERS`, a literal dict in writing order) with
the context an exporter sees. Binary STL lives in assetgen.core, since the simulator reads it
too."""
