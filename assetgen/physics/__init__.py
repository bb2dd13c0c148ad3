"""MJCF physics checks of written modules (`assetgen physics`): each module's exported
`peg_in_hole.xml` is loaded alone and the peg is dropped down its hole and pushed against every
wall, under the same MuJoCo settings the simulator trains with; the report gives the worst
rest errors and penetrations and the modules that fail."""
