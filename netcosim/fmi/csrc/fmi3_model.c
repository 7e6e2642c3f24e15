/* A minimal FMI 3.0 model-exchange and co-simulation FMU around one model header (MODEL_H).
   Co-simulation: doStep integrates with RK4 substeps of at most H_INT s. */
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include "fmi3Functions.h"
#include MODEL_H

/* a model reading the time (TIME_VR: a slot of r not in the XML) gets it from SetTime */
#ifdef TIME_VR
#define SET_TIME(m) ((m)->r[TIME_VR] = (m)->time)
#else
#define SET_TIME(m) ((void)0)
#endif

#define H_INT 1e-3

typedef struct {
    double r[NR];
    double time;
} Instance;

static int failing(Instance *m) { return m->time >= m->r[FAIL_AT_VR]; }

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat; return fmi3OK;
}
static Instance *make(fmi3String token) {
    if (!token || strcmp(token, MODEL_GUID) != 0) return NULL;
    Instance *m = calloc(1, sizeof(Instance));
    memcpy(m->r, START, sizeof(START));
    model_update(m->r);
    return m;
}
fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean vis,
                                          fmi3Boolean log, fmi3InstanceEnvironment env, fmi3LogMessageCallback cb) {
    (void)name; (void)res; (void)vis; (void)log; (void)env; (void)cb;
    return make(token);
}
fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean vis,
                                         fmi3Boolean log, fmi3Boolean evm, fmi3Boolean early,
                                         const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
                                         fmi3LogMessageCallback cb, fmi3IntermediateUpdateCallback iu) {
    (void)name; (void)res; (void)vis; (void)log; (void)evm; (void)early; (void)req; (void)nreq; (void)env;
    (void)cb; (void)iu;
    return make(token);
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean td, fmi3Float64 tol, fmi3Float64 t0,
                                       fmi3Boolean sd, fmi3Float64 t1) {
    (void)td; (void)tol; (void)sd; (void)t1; ((Instance *)c)->time = t0; SET_TIME((Instance *)c); return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { model_update(((Instance *)c)->r); return fmi3OK; }
fmi3Status fmi3EnterEventMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) {
    Instance *m = c; memcpy(m->r, START, sizeof(START)); m->time = 0; return fmi3OK;
}
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Instance *m = c; (void)nv;
    model_update(m->r);
    for (size_t i = 0; i < n; i++) { if (vr[i] >= NR) return fmi3Error; v[i] = m->r[vr[i]]; }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[],
                          size_t nv) {
    Instance *m = c; (void)nv;
    for (size_t i = 0; i < n; i++) { if (vr[i] >= NR) return fmi3Error; m->r[vr[i]] = v[i]; }
    return fmi3OK;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *need, fmi3Boolean *term, fmi3Boolean *nom,
                                    fmi3Boolean *vals, fmi3Boolean *ntd, fmi3Float64 *nt) {
    Instance *m = c; int changed;
    model_event(m->r, m->time, &changed);
    model_update(m->r);
    *need = fmi3False; *term = fmi3False; *nom = fmi3False; *vals = changed; *nt = 0;
    *ntd = model_next_time(m->r, m->time, nt) ? fmi3True : fmi3False;
    return fmi3OK;
}
/* ---- model exchange ---- */
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean nos, fmi3Boolean *ev, fmi3Boolean *term) {
    (void)c; (void)nos; *ev = fmi3False; *term = fmi3False; return fmi3OK;
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { ((Instance *)c)->time = t; SET_TIME((Instance *)c); return fmi3OK; }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t nx) {
    Instance *m = c; for (size_t i = 0; i < nx && i < NX; i++) m->r[STATE_VR[i]] = x[i]; return fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 dx[], size_t nx) {
    Instance *m = c; if (failing(m)) return fmi3Error;
    model_update(m->r); for (size_t i = 0; i < nx && i < NX; i++) dx[i] = m->r[DER_VR[i]]; return fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t nz) {
    Instance *m = c; double zz[NZ + 1];
    model_update(m->r); model_indicators(m->r, zz);
    for (size_t i = 0; i < nz && i < NZ; i++) z[i] = zz[i];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t nx) {
    Instance *m = c; for (size_t i = 0; i < nx && i < NX; i++) x[i] = m->r[STATE_VR[i]]; return fmi3OK;
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t nx) {
    (void)c; for (size_t i = 0; i < nx; i++) x[i] = 1.0; return fmi3OK;
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { (void)c; *n = NZ; return fmi3OK; }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { (void)c; *n = NX; return fmi3OK; }
/* ---- co-simulation ---- */
static void deriv(Instance *m, const double *x, double *dx) {
    double save[NX];
    for (int i = 0; i < NX; i++) { save[i] = m->r[STATE_VR[i]]; m->r[STATE_VR[i]] = x[i]; }
    model_update(m->r);
    for (int i = 0; i < NX; i++) { dx[i] = m->r[DER_VR[i]]; m->r[STATE_VR[i]] = save[i]; }
}
static void rk4(Instance *m, const double *x, double h, double *out) {
    double k1[NX], k2[NX], k3[NX], k4[NX], y[NX];
    deriv(m, x, k1);
    for (int i = 0; i < NX; i++) y[i] = x[i] + 0.5 * h * k1[i];
    deriv(m, y, k2);
    for (int i = 0; i < NX; i++) y[i] = x[i] + 0.5 * h * k2[i];
    deriv(m, y, k3);
    for (int i = 0; i < NX; i++) y[i] = x[i] + h * k3[i];
    deriv(m, y, k4);
    for (int i = 0; i < NX; i++) out[i] = x[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
}
fmi3Status fmi3EnterStepMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noset, fmi3Boolean *ev,
                      fmi3Boolean *term, fmi3Boolean *early, fmi3Float64 *last) {
    Instance *m = c; (void)noset;
    *ev = fmi3False; *term = fmi3False; *early = fmi3False; *last = t;
    if (failing(m)) return fmi3Error;
    if (h > m->r[MAX_STEP_VR]) { h = m->r[MAX_STEP_VR]; *early = fmi3True; }  /* a partial step */
    double x[NX], xn[NX];
    int n = (int)ceil(h / H_INT - 1e-9); if (n < 1) n = 1;
    double step = h / n;
    for (int i = 0; i < NX; i++) x[i] = m->r[STATE_VR[i]];
    for (int k = 0; k < n; k++) {
        rk4(m, x, step, xn);
        for (int i = 0; i < NX; i++) m->r[STATE_VR[i]] = xn[i];
        { int changed; model_event(m->r, t + (k + 1) * step, &changed); }
        for (int i = 0; i < NX; i++) x[i] = m->r[STATE_VR[i]];
    }
    m->time = t + h; *last = m->time;
    model_update(m->r);
    return fmi3OK;
}
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *s) {
    if (!*s) *s = malloc(sizeof(Instance));
    memcpy(*s, c, sizeof(Instance)); return fmi3OK;
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState s) { memcpy(c, s, sizeof(Instance)); return fmi3OK; }
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *s) { (void)c; free(*s); *s = NULL; return fmi3OK; }
