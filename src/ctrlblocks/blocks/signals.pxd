# Declarations for the optional compiled build of the blocks (see base.pxd): a C clamp for
# the compiled PID and ADRC laws.  tests/blocks/test_compiled.py keeps it in step.

cpdef double clamp(double x, double lo, double hi)
