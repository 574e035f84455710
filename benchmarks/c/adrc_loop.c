/* C -O2 reference: ADRC (Euler ESO (4a), law (4b) of Nowak et al. 2018) + 3rd-order linear plant.
 *
 * Same arithmetic, in the same order, as ctrlblocks.fast.kernels.adrc_step in
 * auto mode (reference filter, ESO computed x4 -> x3 -> x2 -> Y_hat, control
 * law, directional anti-windup of x4, output limits) and lti3_step.  The
 * order switches p1..k3 stay run-time values, as in the block.
 *
 * usage: adrc_loop N REPEATS ts b0 l1 l2 l3 l4 p1 p2 k1 k2 k3 kp kd1 kd2 s_u lo hi a_ref
 *                  phi[9] g0[3] c[3] sp
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

static double clampd(double x, double lo, double hi) { return x > hi ? hi : x < lo ? lo : x; }

int main(int argc, char **argv) {
    enum { NP = 18 + 15 + 1 };
    if (argc != 3 + NP) {
        fprintf(stderr, "usage: adrc_loop N REPEATS <18 ADRC params> phi[9] g0[3] c[3] sp\n");
        return 2;
    }
    long n = atol(argv[1]);
    int reps = atoi(argv[2]);
    double p[NP];
    for (int j = 0; j < NP; j++) p[j] = atof(argv[3 + j]);
    double ts = p[0], b0 = p[1], l1 = p[2], l2 = p[3], l3 = p[4], l4 = p[5];
    double p1 = p[6], p2 = p[7], k1 = p[8], k2 = p[9], k3 = p[10];
    double kp = p[11], kd1 = p[12], kd2 = p[13], s_u = p[14], lo = p[15], hi = p[16];
    double a_ref = p[17];
    const double *f = p + 18, *g = p + 27, *cc = p + 30;
    double sp = p[33];
    double *t = malloc(sizeof(double) * reps);
    /* a simulation records its traces, as ctrlblocks.fast.closed_loop does */
    double *y_rec = malloc(sizeof(double) * n), *u_rec = malloc(sizeof(double) * n);
    double y_fin = 0, u_fin = 0;
    for (int r = 0; r < reps; r++) {
        double x0 = 0, x1 = 0, x2 = 0, y = 0;
        double yh = y, e2 = 0, e3 = 0, e4 = 0, u_prev = 0, ref = y, u = 0;
        int sat = 0;
        double t0 = now();
        for (long s = 0; s < n; s++) {
            ref = a_ref * ref + (1.0 - a_ref) * 1.0 * sp;
            double e = y - yh;
            double z3 = e4 + 1.0 * ts * l4 * e;
            double aux = z3 + b0 * u_prev;
            double z2 = e3 + ts * (l3 * e + k3 * aux);
            double z1 = e2 + ts * (p2 * z2 + l2 * e + k2 * aux);
            double z0 = yh + ts * (p1 * z1 + l1 * e + k1 * aux);
            double u_raw = (kp * (ref - z0) - kd1 * z1 - kd2 * z2 - z3) / b0;
            double du = s_u * (z3 - e4);
            if ((sat > 0 && du > 0.0) || (sat < 0 && du < 0.0)) {
                z3 = e4 + 0.0 * ts * l4 * e;
                aux = z3 + b0 * u_prev;
                z2 = e3 + ts * (l3 * e + k3 * aux);
                z1 = e2 + ts * (p2 * z2 + l2 * e + k2 * aux);
                z0 = yh + ts * (p1 * z1 + l1 * e + k1 * aux);
                u_raw = (kp * (ref - z0) - kd1 * z1 - kd2 * z2 - z3) / b0;
            }
            yh = z0; e2 = z1; e3 = z2; e4 = z3;
            u = clampd(u_raw, lo, hi);
            sat = u_raw > hi ? 1 : u_raw < lo ? -1 : 0;
            u_prev = u;
#if RECORD
            y_rec[s] = y;
            u_rec[s] = u;
#endif
            double n0 = g[0] * u + f[0] * x0 + f[1] * x1 + f[2] * x2;
            double n1 = g[1] * u + f[3] * x0 + f[4] * x1 + f[5] * x2;
            double n2 = g[2] * u + f[6] * x0 + f[7] * x1 + f[8] * x2;
            x0 = n0; x1 = n1; x2 = n2;
            y = cc[0] * x0 + cc[1] * x1 + cc[2] * x2;
        }
        t[r] = (now() - t0) / n * 1e9;
        y_fin = y;
        u_fin = u;
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
