/* The Co-Simulation integrator of fmucal's example FMUs, shared by every FMI version's
 * skeleton (fmu_framework2.c, fmu_framework3.c); see fmu_framework.h. It integrates the model
 * hooks with a fixed internal step CS_STEP (classic RK4, or an L-stable SDIRK2 for stiff
 * models, CS_IMPLICIT), shortened to end on communication points and time events, and locates
 * state events by bisection on the event indicators. */

static fmi2Status cs_rhs(Model *m, double t, const double *x, double *dx) {
    m->time = t;
    for (int k = 0; k < NX; k++) STATE(k) = x[k];
    fmi2Status s = model_derivatives(m);
    for (int k = 0; k < NX; k++) dx[k] = DERIV(k);
    return s;
}

#if CS_IMPLICIT
/* Solves A y = b in place (Gaussian elimination with partial pivoting). */
static int cs_solve(double A[NX_ALLOC][NX_ALLOC], double *b) {
    for (int col = 0; col < NX; col++) {
        int piv = col;
        for (int r = col + 1; r < NX; r++) if (fabs(A[r][col]) > fabs(A[piv][col])) piv = r;
        if (fabs(A[piv][col]) < 1e-300) return -1;
        if (piv != col) {
            for (int k = 0; k < NX; k++) { double t = A[col][k]; A[col][k] = A[piv][k]; A[piv][k] = t; }
            double t = b[col]; b[col] = b[piv]; b[piv] = t;
        }
        for (int r = col + 1; r < NX; r++) {
            double f = A[r][col] / A[col][col];
            for (int k = col; k < NX; k++) A[r][k] -= f * A[col][k];
            b[r] -= f * b[col];
        }
    }
    for (int r = NX - 1; r >= 0; r--) {
        for (int k = r + 1; k < NX; k++) b[r] -= A[r][k] * b[k];
        b[r] /= A[r][r];
    }
    return 0;
}

/* One stage of SDIRK: solve Y = base + h*gamma*f(t, Y) by Newton with a finite-difference Jacobian. */
static fmi2Status cs_stage(Model *m, double t, double hg, const double *base, double *Y) {
    double f[NX_ALLOC], fp[NX_ALLOC], J[NX_ALLOC][NX_ALLOC], res[NX_ALLOC];
    for (int it = 0; it < 20; it++) {
        fmi2Status s = cs_rhs(m, t, Y, f);
        if (s > fmi2Warning) return s;
        double norm = 0;
        for (int k = 0; k < NX; k++) {
            res[k] = -(Y[k] - base[k] - hg * f[k]);
            norm = fmax(norm, fabs(res[k]) / (1e-10 + 1e-10 * fabs(Y[k]) + 1e-12 * model_nominal(k)));
        }
        if (norm < 1.0 && it > 0) return fmi2OK;
        for (int j = 0; j < NX; j++) {
            double save = Y[j];
            double d = 1e-8 * fmax(fabs(save), model_nominal(j));
            Y[j] = save + d;
            s = cs_rhs(m, t, Y, fp);
            Y[j] = save;
            if (s > fmi2Warning) return s;
            for (int k = 0; k < NX; k++) J[k][j] = (k == j ? 1.0 : 0.0) - hg * (fp[k] - f[k]) / d;
        }
        if (cs_solve(J, res) != 0) return fmi2Error;
        for (int k = 0; k < NX; k++) Y[k] += res[k];
    }
    return fmi2OK;
}

/* L-stable two-stage SDIRK of order 2 (gamma = 1 - 1/sqrt(2)). */
static fmi2Status cs_step(Model *m, double t, double h, const double *x0, double *x1) {
    const double g = 1.0 - 1.0 / sqrt(2.0);
    double Y1[NX_ALLOC], Y2[NX_ALLOC], k1[NX_ALLOC], base[NX_ALLOC];
    memcpy(Y1, x0, sizeof(double) * NX);
    fmi2Status s = cs_stage(m, t + g * h, h * g, x0, Y1);
    if (s > fmi2Warning) return s;
    s = cs_rhs(m, t + g * h, Y1, k1);
    if (s > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) { base[k] = x0[k] + h * (1.0 - g) * k1[k]; Y2[k] = Y1[k]; }
    s = cs_stage(m, t + h, h * g, base, Y2);
    if (s > fmi2Warning) return s;
    memcpy(x1, Y2, sizeof(double) * NX);
    return fmi2OK;
}
#else
/* Classic fourth-order Runge-Kutta step. */
static fmi2Status cs_step(Model *m, double t, double h, const double *x0, double *x1) {
    double k1[NX_ALLOC], k2[NX_ALLOC], k3[NX_ALLOC], k4[NX_ALLOC], tmp[NX_ALLOC];
    fmi2Status s;
    if ((s = cs_rhs(m, t, x0, k1)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) tmp[k] = x0[k] + 0.5 * h * k1[k];
    if ((s = cs_rhs(m, t + 0.5 * h, tmp, k2)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) tmp[k] = x0[k] + 0.5 * h * k2[k];
    if ((s = cs_rhs(m, t + 0.5 * h, tmp, k3)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) tmp[k] = x0[k] + h * k3[k];
    if ((s = cs_rhs(m, t + h, tmp, k4)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) x1[k] = x0[k] + h / 6.0 * (k1[k] + 2 * k2[k] + 2 * k3[k] + k4[k]);
    return fmi2OK;
}
#endif

static int crossed(const double *z0, const double *z1) {
    for (int k = 0; k < NZ; k++)
        if ((z0[k] > 0 && z1[k] <= 0) || (z0[k] < 0 && z1[k] >= 0)) return 1;
    return 0;
}

/* Advances by h from (t, x0) into the model's states; returns the status of the step. */
static fmi2Status cs_advance_to(Model *m, double t, double h, const double *x0) {
    double x1[NX_ALLOC];
    fmi2Status s = cs_step(m, t, h, x0, x1);
    if (s > fmi2Warning) return s;
    m->time = t + h;
    for (int k = 0; k < NX; k++) STATE(k) = x1[k];
    return model_derivatives(m);
}

static fmi2Status cs_event(Model *m) {
    for (int iter = 0; iter < 100; iter++) {
        m->valuesChanged = 0;
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return s;
        model_event_update(m);
        if (!m->valuesChanged) break;
    }
    return model_derivatives(m);
}

static fmi2Status cs_integrate(Model *m, double tEnd) {
    const double eps = 1e-12 * fmax(1.0, fabs(tEnd));
    while (m->time < tEnd - eps) {
        double t0 = m->time;
        double h = fmin(CS_STEP, tEnd - t0);
        int timeEvent = 0;
        if (m->nextEventTimeDefined && m->nextEventTime <= t0 + h + eps) {
            h = m->nextEventTime - t0;
            timeEvent = 1;
        }
        double x0[NX_ALLOC], z0[NZ_ALLOC], z1[NZ_ALLOC];
        for (int k = 0; k < NX; k++) x0[k] = STATE(k);
        fmi2Status s;
        if (h > 0) {
            if (NZ > 0) model_event_indicators(m, z0);
            if ((s = cs_advance_to(m, t0, h, x0)) > fmi2Warning) return s;
            if (NZ > 0) {
                model_event_indicators(m, z1);
                if (crossed(z0, z1)) {
                    double lo = 0, hi = h;
                    for (int it = 0; it < 80 && hi - lo > 1e-15 * fmax(1.0, fabs(t0)); it++) {
                        double mid = 0.5 * (lo + hi);
                        if ((s = cs_advance_to(m, t0, mid, x0)) > fmi2Warning) return s;
                        model_event_indicators(m, z1);
                        if (crossed(z0, z1)) hi = mid; else lo = mid;
                    }
                    if ((s = cs_advance_to(m, t0, hi, x0)) > fmi2Warning) return s;
                    timeEvent = 0;
                    if ((s = cs_event(m)) > fmi2Warning) return s;
                }
            }
        }
        if (timeEvent) {
            m->time = m->nextEventTime;
            m->nextEventTimeDefined = 0;
            if ((s = cs_event(m)) > fmi2Warning) return s;
        }
        if (m->terminateSimulation) return fmi2Discard;
    }
    m->time = tEnd;
    return fmi2OK;
}

