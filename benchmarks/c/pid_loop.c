/* C -O2 reference ("the floor"): PID + 3rd-order linear plant, closed loop.
 *
 * Same arithmetic, in the same order, as ctrlblocks.fast.kernels.pid_step
 * (ISA PID, setpoint weights b and c, filtered derivative Åström 1987, (2.13),
 * integral increment (2.8)/Tustin, output limits, clamping anti-windup) and
 * lti3_step (exact ZOH plant, LinearPlant (2)).  State in local variables.
 *
 * usage: pid_loop N REPEATS k sgn b c ad bd ki_h alpha beta lo hi phi[9] g0[3] c[3] sp
 * prints: ns_per_step (min over repeats) ns_median y_final u_final
 * Built by benchmarks/run.py with the system compiler: cc -O2 (and -DRECORD=0
 * for the bare loop that keeps no traces).
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#ifndef RECORD
#define RECORD 1 /* -DRECORD=0: the bare loop, no traces */
#endif

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double clampd(double x, double lo, double hi) { return x < lo ? lo : x > hi ? hi : x; }

int main(int argc, char **argv) {
    if (argc != 3 + 27) {
        fprintf(stderr, "usage: pid_loop N REPEATS k sgn b c ad bd ki_h alpha beta lo hi phi[9] g0[3] c[3] sp\n");
        return 2;
    }
    long n = atol(argv[1]);
    int reps = atoi(argv[2]);
    double p[27];
    for (int j = 0; j < 27; j++) p[j] = atof(argv[3 + j]);
    double k = p[0], sgn = p[1], b = p[2], c = p[3], ad = p[4], bd = p[5], ki_h = p[6];
    double alpha = p[7], beta = p[8], lo = p[9], hi = p[10];
    const double *f = p + 11, *g = p + 20, *cc = p + 23;
    double sp = p[26];
    double *t = malloc(sizeof(double) * reps);
    /* a simulation records its traces, as ctrlblocks.fast.closed_loop does */
    double *y_rec = malloc(sizeof(double) * n), *u_rec = malloc(sizeof(double) * n);
    double y_fin = 0, u_fin = 0;
    for (int r = 0; r < reps; r++) {
        double i = 0, d = 0, w_prev = 0, e_prev = 0, out = 0;
        double x0 = 0, x1 = 0, x2 = 0, y = 0;
        int cold = 1;
        double t0 = now();
        for (long s = 0; s < n; s++) {
            double e = sgn * (sp - y);
            double pp = k * sgn * (b * sp - y);
            double w = sgn * (c * sp - y);
            if (cold) { w_prev = w; d = 0.0; e_prev = e; }
            d = ad * d + bd * (w - w_prev);
            double i_k = i;
            if (!cold && ki_h != 0.0) {
                double di = ki_h * (alpha * e_prev + beta * e);
                i_k = i + di;
                double v = pp + i_k + d;
                if ((v > hi && di > 0.0) || (v < lo && di < 0.0)) i_k = i;
            }
            double v_raw = pp + i_k + d;
            out = clampd(v_raw, lo, hi);
            i = i_k;
            w_prev = w;
            e_prev = e;
            cold = 0;
#if RECORD
            y_rec[s] = y;
            u_rec[s] = out;
#endif
            double n0 = g[0] * out + f[0] * x0 + f[1] * x1 + f[2] * x2;
            double n1 = g[1] * out + f[3] * x0 + f[4] * x1 + f[5] * x2;
            double n2 = g[2] * out + f[6] * x0 + f[7] * x1 + f[8] * x2;
            x0 = n0; x1 = n1; x2 = n2;
            y = cc[0] * x0 + cc[1] * x1 + cc[2] * x2;
        }
        t[r] = (now() - t0) / n * 1e9;
        y_fin = y;
        u_fin = out;
    }
    double tmin = t[0];
    for (int r = 1; r < reps; r++) if (t[r] < tmin) tmin = t[r];
    qsort(t, reps, sizeof(double), cmp);
    printf("%.4f %.4f %.17g %.17g\n", tmin, t[reps / 2], y_fin, u_fin);
    if (n > 0 && y_rec[n - 1] != y_rec[n - 1]) printf("nan\n"); /* keep the traces */
    free(t);
    free(y_rec);
    free(u_rec);
    return 0;
}
