"""Stage 3, checks: every module is verified on its STL files as written, before anything is
renamed into place: closed, consistently oriented, one body, genus 0, positive volume, the
peg-to-module distance in the design pose equal to the clearance (python-fcl), and the
straight insertion along the hole axis free of collision."""
