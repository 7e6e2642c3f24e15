/* A minimal FMI 3.0 Scheduled Execution FMU with two clocked model partitions.
   Clocks (input, constant intervals from modelDescription.xml): 1 "fast", 2 "slow".
   Each activation of a partition counts itself and records its activation time:
   vr 3 fast_count, 4 fast_time (s), 5 slow_count, 6 slow_time (s); vr 7 gain (parameter),
   vr 8 fast_out = gain * fast_count (output of the fast partition). */
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

#define GUID "{netcosim-se-1}"
#define NR 9

typedef struct { double r[NR]; } Instance;

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) {
    (void)c; (void)on; (void)n; (void)cat; return fmi3OK;
}
fmi3Instance fmi3InstantiateScheduledExecution(fmi3String name, fmi3String token, fmi3String res, fmi3Boolean vis,
        fmi3Boolean log, fmi3InstanceEnvironment env, fmi3LogMessageCallback cb, fmi3ClockUpdateCallback cu,
        fmi3LockPreemptionCallback lp, fmi3UnlockPreemptionCallback up) {
    (void)name; (void)res; (void)vis; (void)log; (void)env; (void)cb; (void)cu; (void)lp; (void)up;
    if (!token || strcmp(token, GUID) != 0) return NULL;
    Instance *m = calloc(1, sizeof(Instance));
    m->r[7] = 2.0;
    return m;
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean td, fmi3Float64 tol, fmi3Float64 t0,
                                       fmi3Boolean sd, fmi3Float64 t1) {
    (void)c; (void)td; (void)tol; (void)t0; (void)sd; (void)t1; return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { (void)c; return fmi3OK; }
fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Instance *m = c; (void)nv;
    for (size_t i = 0; i < n; i++) { if (vr[i] >= NR) return fmi3Error; v[i] = m->r[vr[i]]; }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[],
                          size_t nv) {
    Instance *m = c; (void)nv;
    for (size_t i = 0; i < n; i++) { if (vr[i] >= NR) return fmi3Error; m->r[vr[i]] = v[i]; }
    return fmi3OK;
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clock, fmi3Float64 t) {
    Instance *m = c;
    if (clock == 1) { m->r[3] += 1; m->r[4] = t; m->r[8] = m->r[7] * m->r[3]; return fmi3OK; }
    if (clock == 2) { m->r[5] += 1; m->r[6] = t; return fmi3OK; }
    return fmi3Error;
}
