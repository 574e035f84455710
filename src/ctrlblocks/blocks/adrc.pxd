# Declarations for the optional compiled build of the blocks (see base.pxd): ADRC as an
# extension type whose float state is C doubles, and the per-call law functions with
# C arguments (the interpreted functions of adrc.py stay what ctrlblocks.fast compiles
# with numba and the float32 cycle rebuilds).  adrc_law's parameter tuples are C tuples
# and its constant ones (NO_EXACT, NO_ANTI_BACKOFF) C values: the fast lane passes them
# without converting (issue 31: the Python tuples cost the compiled ADRC 46 %).  The attributes declared here are
# ADRC._declared; tests/blocks/test_compiled.py keeps this file in step with adrc.py.

cimport cython
from .signals cimport clamp

cdef double _INF, _NINF
cpdef (double, double, double, double) eso_euler(
    double yh, double x2, double x3, double x4, double u_prev, double y, double w4, double ts,
    double b0, double l1, double l2, double l3, double l4, double p1, double p2, double k1,
    double k2, double k3)
cpdef double control_law(double r, double yh, double x2, double x3, double x4, double b0,
                         double kp, double kd1, double kd2)
cpdef double x4_update_allowed(long rule, bint awin, long sat, double du)
cpdef (double, double, double, double) solve_x4(
    double u_target, double u_law, double yh, double x2, double x3, double x4, double s_yh,
    double s_x2, double s_x3, double s_u)
@cython.locals(ts=cython.double, b0=cython.double, l1=cython.double, l2=cython.double, l3=cython.double,
               l4=cython.double, p1=cython.double, p2=cython.double, k1=cython.double,
               k2=cython.double, k3=cython.double, kp=cython.double, kd1=cython.double,
               kd2=cython.double, s_yh=cython.double, s_x2=cython.double,
               s_x3=cython.double, s_u=cython.double, lo=cython.double, hi=cython.double,
               rule=cython.double, a_ref=cython.double, a_q=cython.double, nsub=cython.double,
               r=cython.double, f01=cython.double, f02=cython.double, f03=cython.double, f12=cython.double,
               f13=cython.double, f23=cython.double, g0=cython.double, g1=cython.double,
               g2=cython.double, c0=cython.double, c1=cython.double, c2=cython.double,
               c3=cython.double, y_sat=cython.double, y_sat_lo=cython.double,
               tau_wait=cython.double, ysat=cython.double,
               z0=cython.double, z1=cython.double, z2=cython.double, z3=cython.double,
               u_free=cython.double, du=cython.double, u_raw=cython.double,
               now=cython.long, end_wait=cython.bint, sat_next=cython.long)
cpdef (double, double, double, double, double, double, double, double, bint, long, long,
       double) adrc_law(
    double r_in, double y, double ff, bint manual, double target, bint tracking, bint started, long sat,
    bint awin, bint exact, bint ab_on, double yh, double x2, double x3, double x4, double u_eso,
    double u_prev, double ref, double q, long ab_sat, double ab_wait,
    (double, double, double, double, double, double, double, double, double, double, double,
     double, double, double, double, double, double, double, double, double, double, double,
     double, double) prm,
    (double, double, double, double, double, double, double, double, double, double, double,
     double, double) ecoef,
    (double, double, double) ab)
cdef (double, double, double, double, double, double, double, double, double, double, double,
      double, double) NO_EXACT
cdef (double, double, double) NO_ANTI_BACKOFF
cpdef double handover_offset(double target, double ref, double yh, double x2, double x3,
                             double x4, double b0, double kp, double kd1, double kd2)
@cython.locals(lo=cython.double, hi=cython.double, target=cython.double, u=cython.double,
               u_raw=cython.double, end_wait=cython.bint, sat_next=cython.long,
               _ab_sat=cython.long, _ab_wait=cython.double)
cpdef (double, double, double, double, double, double, double, double, bint, long) adrc_step(
    double sp, double y, bint manual, double u_man, bint started, bint track, long sat,
    double yh, double x2, double x3, double x4, double u_prev, double ref, double q, object prm,
    bint awin=*)

from .base cimport Block, as_input

cdef class ADRC(Block):
    cdef public object manual, awin, u_man, _lean, _started, _pending, _track, _prm, _sat
    cdef public object _limits_bad, _warn, awout, _eso, _eso_coef, _gains, _law, _sens
    cdef public object _ab_sat, _nd, _u_hist, track, hold, track_value, reset_active
    cdef public double out, _h, _ts, _yh, _x2, _x3, _x4, _u_prev, _ref, u_raw, y, e
    cdef public double y_ref, _u_lo, _u_hi, _q, _ff_prev, ff, _sp_f, _pv_f, _sp_w, sp_w
    cpdef output_limits(self)
    cdef _call(self, double sp, double y, pv_ok, y_ok, u_real, dt, double ff=*)
    cdef _compute_output(self, sp, y, pv_ok, y_ok, dt, ff=*)
    cdef _fast_cycle(self, double sp, double y)
