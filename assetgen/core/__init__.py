"""Shared numpy-only pieces of the generator, the simulator and the preview: triangle meshes,
binary STL, frames and quaternions, CPU-independent products (portable), the one MuJoCo
configuration, atomic file writes, paths as result files record them, and step timing.
Nothing here imports the CAD stack, so a machine that only reads datasets and trains needs
none of it."""
