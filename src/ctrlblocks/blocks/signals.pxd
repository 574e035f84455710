# Declarations for the optional compiled build of the blocks (see base.pxd): a C clamp,
# dead band and ramp step for the compiled PID and ADRC laws.  tests/blocks/test_compiled.py
# keeps it in step.

cpdef double clamp(double x, double lo, double hi)
cpdef double deadband(double u, double width)
cpdef (double, bint) rate_limit_step(double u, double y, double up, double down, double h)
