/* A minimal FMI 2.0 model-exchange and co-simulation FMU around one model header (MODEL_H).
   Co-simulation: doStep integrates with RK4 substeps of at most H_INT s, events by bisection. */
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include "fmi2Functions.h"
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
    int cs;
    fmi2CallbackFunctions cb;
} Instance;

static int failing(Instance *m) { return m->time >= m->r[FAIL_AT_VR]; }

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c; (void)on; (void)n; (void)cat; return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String res,
                              const fmi2CallbackFunctions *cb, fmi2Boolean vis, fmi2Boolean log) {
    (void)name; (void)res; (void)vis; (void)log;
    if (!guid || strcmp(guid, MODEL_GUID) != 0) return NULL;
    Instance *m = calloc(1, sizeof(Instance));
    memcpy(m->r, START, sizeof(START));
    m->cs = type == fmi2CoSimulation;
    if (cb) m->cb = *cb;
    model_update(m->r);
    return m;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd,
                               fmi2Real t1) {
    (void)td; (void)tol; (void)sd; (void)t1;
    ((Instance *)c)->time = t0; SET_TIME((Instance *)c); return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { model_update(((Instance *)c)->r); return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) {
    Instance *m = c; memcpy(m->r, START, sizeof(START)); m->time = 0; return fmi2OK;
}
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    Instance *m = c;
    model_update(m->r);
    for (size_t i = 0; i < n; i++) { if (vr[i] >= NR) return fmi2Error; v[i] = m->r[vr[i]]; }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]) {
    Instance *m = c;
    for (size_t i = 0; i < n; i++) { if (vr[i] >= NR) return fmi2Error; m->r[vr[i]] = v[i]; }
    return fmi2OK;
}
/* ---- model exchange ---- */
fmi2Status fmi2EnterEventMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Instance *m = c; int changed;
    model_event(m->r, m->time, &changed);
    model_update(m->r);
    e->newDiscreteStatesNeeded = fmi2False; e->terminateSimulation = fmi2False;
    e->nominalsOfContinuousStatesChanged = fmi2False; e->valuesOfContinuousStatesChanged = changed;
    e->nextEventTime = 0;
    e->nextEventTimeDefined = model_next_time(m->r, m->time, &e->nextEventTime) ? fmi2True : fmi2False;
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean nos, fmi2Boolean *ev, fmi2Boolean *term) {
    (void)c; (void)nos; *ev = fmi2False; *term = fmi2False; return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Instance *)c)->time = t; SET_TIME((Instance *)c); return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Instance *m = c; for (size_t i = 0; i < nx && i < NX; i++) m->r[STATE_VR[i]] = x[i]; return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t nx) {
    Instance *m = c; if (failing(m)) return fmi2Error;
    model_update(m->r); for (size_t i = 0; i < nx && i < NX; i++) dx[i] = m->r[DER_VR[i]]; return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t nz) {
    Instance *m = c; double zz[NZ + 1];
    model_update(m->r); model_indicators(m->r, zz);
    for (size_t i = 0; i < nz && i < NZ; i++) z[i] = zz[i];
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Instance *m = c; for (size_t i = 0; i < nx && i < NX; i++) x[i] = m->r[STATE_VR[i]]; return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    (void)c; for (size_t i = 0; i < nx; i++) x[i] = 1.0; return fmi2OK;
}
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
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noset) {
    Instance *m = c; (void)noset;
    if (failing(m)) return fmi2Error;
    if (h > m->r[MAX_STEP_VR]) return fmi2Discard;    /* rejected: nothing computed, time stays t */
    double t_end = t + h, x[NX], xn[NX];
    int n = (int)ceil(h / H_INT - 1e-9); if (n < 1) n = 1;
    double step = h / n;
    for (int i = 0; i < NX; i++) x[i] = m->r[STATE_VR[i]];
    for (int k = 0; k < n; k++) {
        rk4(m, x, step, xn);
        memcpy(x, xn, sizeof(x));
        for (int i = 0; i < NX; i++) m->r[STATE_VR[i]] = x[i];
        { int changed; model_event(m->r, t + (k + 1) * step, &changed);
                      for (int i = 0; i < NX; i++) x[i] = m->r[STATE_VR[i]]; }
    }
    m->time = t_end;
    model_update(m->r);
    return fmi2OK;
}
fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = ((Instance *)c)->time; return fmi2OK;
}
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    if (!*s) *s = malloc(sizeof(Instance));
    memcpy(*s, c, sizeof(Instance)); return fmi2OK;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { memcpy(c, s, sizeof(Instance)); return fmi2OK; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; free(*s); *s = NULL; return fmi2OK; }
