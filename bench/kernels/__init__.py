"""Stepping kernels shared by several schemes (the Newmark family, the lumped explicit
step, the boundary-contact step) and the Python glue around them."""
