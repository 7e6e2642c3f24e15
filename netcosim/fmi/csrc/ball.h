/* Bouncing ball: x = (h, v) (m, m/s), a state event when h reaches 0 falling: v <- -e v.
   Value references: 0 h, 1 v, 2 der(h), 3 der(v), 4 g (m/s^2), 5 e (restitution), 6 fail_at, 7 max_step.
   The event indicator is h (m); the bounce fires when h <= 1e-9 m while v < 0. */
#define MODEL_GUID "{netcosim-ball-1}"
#define NX 2
#define NZ 1
#define NR 8
#define FAIL_AT_VR 6
#define MAX_STEP_VR 7
static const double START[NR] = {1.0, 0, 0, 0, 9.81, 0.7, 1e300, 1e300};
static const int STATE_VR[NX] = {0, 1};
static const int DER_VR[NX] = {2, 3};

static void model_update(double *r) {
    r[2] = r[1];
    r[3] = -r[4];
}
static void model_indicators(const double *r, double *z) { z[0] = r[0]; }
static void model_event(double *r, double time, int *changed) {
    (void)time;
    *changed = 0;
    if (r[0] <= 1e-9 && r[1] < 0) {
        r[0] = 0.0;
        r[1] = -r[5] * r[1];
        *changed = 1;
    }
}
static int model_next_time(const double *r, double time, double *next) { (void)r; (void)time; (void)next; return 0; }
