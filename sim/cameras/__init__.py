"""Cameras for the env: depth and RGB images of the module and its peg, rendered offscreen by
MuJoCo on the CPU (EGL or OSMesa). docs/cameras.md says what they see and what they cost."""
