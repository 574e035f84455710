# Declarations for the optional compiled build of the blocks (see base.pxd): PID as an
# extension type whose float state is C doubles, and the per-call law functions with
# C arguments (the interpreted functions of pid.py stay what ctrlblocks.fast compiles
# with numba and the float32 cycle rebuilds).  The parameter tuples of the one law
# (pid_law's prm and opt) are C tuples: a caller in C passes them without converting.
# The attributes declared here are PID._declared; tests/blocks/test_compiled.py keeps
# this file in step with pid.py.

cimport cython
from .signals cimport clamp, deadband, rate_limit_step

cdef double _INF, _NINF
cpdef double derivative_step(double a, double bd, double d_prev, double w, double w_prev)
cpdef double integral_increment(double ki_h, double alpha, double beta, double e_prev, double e)
cpdef bint clamping_blocks(double di, double v, double lo, double hi)
cpdef double clamping_integral(double i, double di, double rest, double lo, double hi)
cpdef bint ramp_blocks(double di, double v, double y_prev, double step_max)
@cython.locals(out=cython.double, limiting=cython.bint)
cpdef (double, bint) pid_output(double v, double ramp_y, double lo, double hi, double rate_h)
@cython.locals(k=cython.double, sgn=cython.double, b=cython.double, c=cython.double,
               ad=cython.double, bd=cython.double, ki_h=cython.double, alpha=cython.double,
               beta=cython.double, lo=cython.double, hi=cython.double, aw=cython.double,
               g=cython.double, velocity=cython.double, dev_tol=cython.double,
               rate_h=cython.double, db=cython.double, i_band=cython.double,
               frozen=cython.bint, e=cython.double, p=cython.double,
               w=cython.double, dn=cython.double, db_held=cython.bint, i_k=cython.double,
               v_raw=cython.double, di=cython.double, out=cython.double,
               limiting=cython.bint)
cpdef (double, double, bint, double, double, double, double, double, double, bint,
       bint) pid_law(
    double sp, double pv, double ff, bint held, double target, bint hist, bint transfer,
    bint suppressed, bint awin, bint db_active, double db_hold, double i, double d,
    double w_prev, double e_prev, double x, double bias, double p_prev, double d_prev,
    double ff_prev, double out_prev, double ramp_y,
    (double, double, double, double, double, double, double, double, double, double, double,
     double, double) prm,
    (double, double, double, double, double) opt)
cdef (double, double, double, double, double) NO_OPTIONS
@cython.locals(ref=cython.double, v=cython.double)
cpdef (double, double) pid_commit(
    double u, double out, double v_raw, double p, double i_k, double d, double ff, bint held,
    bint pos_ok, double actuator_pos, double ki_h, double aw, double g, double velocity)
@cython.locals(out=cython.double, v_raw=cython.double, _lim=cython.bint, p=cython.double,
               i_k=cython.double, dn=cython.double, w=cython.double, e=cython.double,
               _bias=cython.double, _sup=cython.bint, _dbh=cython.bint, i_new=cython.double,
               _x=cython.double)
cpdef (double, double, double, double, double, double, double, double) pid_step(
    double sp, double pv, double ff, bint manual, double u_man, bint cold, bint transfer,
    double i, double d, double w_prev, double e_prev, double out_prev,
    (double, double, double, double, double, double, double, double, double, double, double,
     double, double) prm)

from .base cimport Block, as_input

ctypedef (double, double, double, double, double, double, double, double, double, double,
          double, double, double) pid_prm_t
# the lean two-phase cycle pending (PID._pending is True): what update_state commits with
# pid_commit, and the committed values before it (PID._lean_cycle; docs/performance.md)
ctypedef (double, double, double, double, double, double, double, double, double, double,
          double, double, double) pid_lean_t

cdef class PID(Block):
    cdef public object manual, track, hold, reset_active, awin, manual_value, _lean
    cdef public object _mode_prev, _cold, _reinit, _pending, limits_active
    # the law's parameters as the C tuple pid_law takes: converted when set (configure),
    # not at every call (docs/performance.md, "Instructions per call")
    cdef public pid_prm_t _prm
    cdef public pid_lean_t _lean_cycle
    cdef public bint _two_phase_lean
    cdef public object _limits_status, _lean_ran, _law_in_force, deadband_active
    cdef public object p_suppressed
    cdef public double out, _h, _ts, _i, _d, _w_prev, _e_prev, p, i, d, e, sp_w, pv_f, ff
    cdef public double _lo, _hi, _x, _bias, _ff_prev
    cpdef output_limits(self)
    cdef bint _plain_auto(self, dt, pv_ok, double dv)
    @cython.locals(prm=pid_prm_t, out_prev=cython.double, out=cython.double,
                   v_raw=cython.double, _lim=cython.bint, p=cython.double, i_k=cython.double,
                   d=cython.double, e=cython.double, _bias=cython.double, _sup=cython.bint,
                   _dbh=cython.bint, _x=cython.double)
    cdef _call(self, double sp, double pv, double ff, double dv, dt, pv_ok)
    cdef _compute_output(self, double sp, double pv, double ff, double dv, dt, pv_ok)
