"""Stepping kernels of the schemes (the Newmark family, the lumped explicit step, the
boundary-contact step, each scheme's own compiled step) and the Python glue around them."""
