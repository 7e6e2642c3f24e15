/* DC servo k / (s (s + a)): x = (angle, velocity), u (V), y = angle (rad).
   Value references: 0 angle, 1 velocity, 2 der(angle), 3 der(velocity), 4 u, 5 y, 6 k, 7 a,
   8 fail_at (s: from this time on the derivatives and doStep return an error; a test of error handling),
   9 max_step (s: co-simulation steps longer than this are rejected (FMI 2) or end early (FMI 3)). */
#define MODEL_GUID "{netcosim-servo-1}"
#define NX 2
#define NZ 0
#define NR 10
#define FAIL_AT_VR 8
#define MAX_STEP_VR 9
static const double START[NR] = {0, 0, 0, 0, 0, 0, 1000.0, 1.0, 1e300, 1e300};
static const int STATE_VR[NX] = {0, 1};
static const int DER_VR[NX] = {2, 3};

static void model_update(double *r) {       /* derivatives and outputs from states, inputs, parameters */
    r[2] = r[1];
    r[3] = -r[7] * r[1] + r[6] * r[4];
    r[5] = r[0];
}
static void model_indicators(const double *r, double *z) { (void)r; (void)z; }
static void model_event(double *r, double time, int *changed) {
    (void)time; (void)r; *changed = 0; }
static int model_next_time(const double *r, double time, double *next) { (void)r; (void)time; (void)next; return 0; }
