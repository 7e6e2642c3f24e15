/* A ramp with a time event: x' = slope, slope = 1 until T (s), then -1, so x(t) = t before
   T and 2 T - t after.  The FMU announces T as its next event time.
   Value references: 0 x, 1 der(x), 2 slope (discrete), 3 T (s), 4 fail_at, 5 max_step, 6 y = x. */
#define MODEL_GUID "{netcosim-ramp-1}"
#define NX 1
#define NZ 0
#define NR 7
#define FAIL_AT_VR 4
#define MAX_STEP_VR 5
static const double START[NR] = {0, 0, 1.0, 0.5, 1e300, 1e300, 0};
static const int STATE_VR[NX] = {0};
static const int DER_VR[NX] = {1};

static void model_update(double *r) {
    r[1] = r[2];
    r[6] = r[0];
}
static void model_indicators(const double *r, double *z) { (void)r; (void)z; }
static void model_event(double *r, double time, int *changed) {
    *changed = 0;
    if (r[2] > 0 && time >= r[3]) r[2] = -1.0;     /* a discrete change: the state is continuous */
}
static int model_next_time(const double *r, double time, double *next) {
    (void)time;
    if (r[2] > 0) { *next = r[3]; return 1; }
    return 0;
}
