/* A small FMI 2.0 master in C, the way a Windows tool loads an FMU (issue 25): LoadLibrary on
 * Windows (compiled with MinGW, run under wine by tools/windows.sh), dlopen on Linux (compiled
 * with gcc, run natively on the .so for the reference). The same source, so the two CSVs differ
 * only by the binary.
 *
 *   fmi_master <library> <guid> cs      <scene.txt> <out.csv>   Co-Simulation run of a scene
 *   fmi_master <library> <guid> me      <scene.txt> <out.csv>   Model Exchange, fixed-step RK4
 *   fmi_master <library> <guid> states  <scene.txt> <out.blob>  FMU state get/set/serialize
 *   fmi_master <library> <guid> threads <scene.txt>             two instances in two threads
 *   fmi_master <library> <guid> errors                          bad input (SpurGearMesh only)
 *   fmi_master <library> <guid> blob    <scene.txt> <in.blob> <out.csv>
 *                                       continue a state serialized by another binary
 *
 * The scene file (written by tests/windows/scene_file.py from scenes/<name>.toml and the FMU's
 * modelDescription.xml) is one item a line:
 *   stop_time <t> | output_interval <dt> | nx <n> | nz <n> | me_step <h>
 *   real <vr> <x> | integer <vr> <i> | boolean <vr> <0|1> | string <vr> <text to the line's end>
 *   input <vr>                the columns of the input table, in order
 *   row <t> <u1> <u2> ...     the input table: linear interpolation at every communication point,
 *                             held over the step (as examples/run_scene.rs)
 *   output <vr> <name>        the CSV's columns, read after every step with one fmi2GetReal
 * Exits 0 if every check passed; messages on stderr.
 */
#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#include <pthread.h>
#endif
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"

#define MAXV 64
#define MAXROWS 256
#define MAXX 64
#define MAXZ 256

static int failures = 0;

#define CHECK(cond, ...)                                                   \
    do {                                                                   \
        if (!(cond)) {                                                     \
            fprintf(stderr, "fmi_master: line %d: ", __LINE__);            \
            fprintf(stderr, __VA_ARGS__);                                  \
            fprintf(stderr, "\n");                                         \
            failures++;                                                    \
        }                                                                  \
    } while (0)

/* ---- the library ---------------------------------------------------------------------------- */

struct api {
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetDebugLoggingTYPE *SetDebugLogging;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2TerminateTYPE *Terminate;
    fmi2ResetTYPE *Reset;
    fmi2GetRealTYPE *GetReal;
    fmi2SetRealTYPE *SetReal;
    fmi2SetIntegerTYPE *SetInteger;
    fmi2SetBooleanTYPE *SetBoolean;
    fmi2SetStringTYPE *SetString;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *DeSerializeFMUstate;
    fmi2DoStepTYPE *DoStep;
    fmi2GetRealStatusTYPE *GetRealStatus;
    fmi2CancelStepTYPE *CancelStep;
    fmi2EnterEventModeTYPE *EnterEventMode;
    fmi2NewDiscreteStatesTYPE *NewDiscreteStates;
    fmi2EnterContinuousTimeModeTYPE *EnterContinuousTimeMode;
    fmi2CompletedIntegratorStepTYPE *CompletedIntegratorStep;
    fmi2SetTimeTYPE *SetTime;
    fmi2SetContinuousStatesTYPE *SetContinuousStates;
    fmi2GetDerivativesTYPE *GetDerivatives;
    fmi2GetEventIndicatorsTYPE *GetEventIndicators;
    fmi2GetContinuousStatesTYPE *GetContinuousStates;
};

static struct api f;
static const char *guid;
/* The resource location passed to fmi2Instantiate (FMI_MASTER_RESOURCES, a file URI): a gearbox
 * FMU reads its file from there; the other FMUs need none. */
static const char *resources = "";

static void *sym(void *lib, const char *name) {
#ifdef _WIN32
    void *p = (void *)GetProcAddress((HMODULE)lib, name);
#else
    void *p = dlsym(lib, name);
#endif
    if (!p) {
        fprintf(stderr, "fmi_master: %s is not exported\n", name);
        exit(2);
    }
    return p;
}

static void *load(const char *path) {
#ifdef _WIN32
    HMODULE lib = LoadLibraryA(path);
    if (!lib) {
        fprintf(stderr, "fmi_master: LoadLibrary(%s) failed: error %lu\n", path, (unsigned long)GetLastError());
        exit(2);
    }
    return (void *)lib;
#else
    void *lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "fmi_master: %s\n", dlerror());
        exit(2);
    }
    return lib;
#endif
}

static void unload(void *lib) {
#ifdef _WIN32
    FreeLibrary((HMODULE)lib);
#else
    dlclose(lib);
#endif
}

/* ---- the logger: a real C-variadic function; remembers the last error message ------------- */

static long messages = 0, error_messages = 0;
static char last_error[4200];
static int verbose = 0;

static void logger_impl(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    char text[4096];
    va_list ap;
    (void)env;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message, ap);
    va_end(ap);
    messages++;
    if (status >= fmi2Discard) {
        error_messages++;
        snprintf(last_error, sizeof last_error, "[%s] %s", category ? category : "", text);
    }
    if (verbose) fprintf(stderr, "[%s %d %s] %s\n", instance, (int)status, category, text);
}

static fmi2CallbackFunctions callbacks = {logger_impl, calloc, free, NULL, NULL};

/* ---- the scene ------------------------------------------------------------------------------ */

enum kind { K_REAL, K_INTEGER, K_BOOLEAN, K_STRING };

struct start {
    enum kind kind;
    fmi2ValueReference vr;
    double x;
    char *s;
};

struct scene {
    double stop_time, dt, me_step;
    int nx, nz;
    struct start starts[MAXV];
    int nstarts;
    fmi2ValueReference in_vr[MAXV];
    int nin;
    double rows[MAXROWS][MAXV + 1];
    int nrows;
    fmi2ValueReference out_vr[MAXV];
    char out_name[MAXV][64];
    int nout;
};

static struct scene sc;

static void read_scene(const char *path) {
    char line[8192];
    FILE *in = fopen(path, "r");
    memset(&sc, 0, sizeof sc);
    sc.me_step = 1e-6;
    if (!in) {
        fprintf(stderr, "fmi_master: cannot open %s\n", path);
        exit(2);
    }
    while (fgets(line, sizeof line, in)) {
        char key[32];
        int used = 0;
        unsigned vr;
        line[strcspn(line, "\r\n")] = 0;
        if (sscanf(line, "%31s %n", key, &used) != 1) continue;
        if (!strcmp(key, "stop_time")) sc.stop_time = atof(line + used);
        else if (!strcmp(key, "output_interval")) sc.dt = atof(line + used);
        else if (!strcmp(key, "me_step")) sc.me_step = atof(line + used);
        else if (!strcmp(key, "nx")) sc.nx = atoi(line + used);
        else if (!strcmp(key, "nz")) sc.nz = atoi(line + used);
        else if (!strcmp(key, "input")) sc.in_vr[sc.nin++] = (fmi2ValueReference)atol(line + used);
        else if (!strcmp(key, "output")) {
            int n2 = 0;
            sscanf(line + used, "%u %63s%n", &vr, sc.out_name[sc.nout], &n2);
            sc.out_vr[sc.nout++] = vr;
        } else if (!strcmp(key, "row")) {
            char *p = line + used, *end;
            int j;
            for (j = 0; j <= sc.nin; j++) {
                sc.rows[sc.nrows][j] = strtod(p, &end);
                p = end;
            }
            sc.nrows++;
        } else {
            struct start *s = &sc.starts[sc.nstarts++];
            int n2 = 0;
            sscanf(line + used, "%u %n", &vr, &n2);
            s->vr = vr;
            if (!strcmp(key, "real")) { s->kind = K_REAL; s->x = strtod(line + used + n2, NULL); }
            else if (!strcmp(key, "integer")) { s->kind = K_INTEGER; s->x = atof(line + used + n2); }
            else if (!strcmp(key, "boolean")) { s->kind = K_BOOLEAN; s->x = atof(line + used + n2); }
            else if (!strcmp(key, "string")) { s->kind = K_STRING; s->s = malloc(strlen(line + used + n2) + 1); strcpy(s->s, line + used + n2); }
            else { fprintf(stderr, "fmi_master: unknown line '%s'\n", line); exit(2); }
        }
        if (sc.nstarts >= MAXV || sc.nin >= MAXV || sc.nout >= MAXV || sc.nrows >= MAXROWS) {
            fprintf(stderr, "fmi_master: scene too large\n");
            exit(2);
        }
    }
    fclose(in);
}

/* The inputs at time t: linear interpolation in the table, constant outside. */
static void inputs_at(double t, double *u) {
    int i, j;
    for (j = 0; j < sc.nin; j++) {
        if (t <= sc.rows[0][0]) { u[j] = sc.rows[0][j + 1]; continue; }
        if (t >= sc.rows[sc.nrows - 1][0]) { u[j] = sc.rows[sc.nrows - 1][j + 1]; continue; }
        for (i = 0; i + 1 < sc.nrows && sc.rows[i + 1][0] < t; i++) {}
        {
            double t0 = sc.rows[i][0], t1 = sc.rows[i + 1][0];
            double w = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
            u[j] = sc.rows[i][j + 1] + w * (sc.rows[i + 1][j + 1] - sc.rows[i][j + 1]);
        }
    }
}

static void set_inputs(fmi2Component c, double t) {
    double u[MAXV];
    if (!sc.nin) return;
    inputs_at(t, u);
    CHECK(f.SetReal(c, sc.in_vr, sc.nin, u) == fmi2OK, "inputs at t = %g: %s", t, last_error);
}

static void apply_starts(fmi2Component c) {
    int k;
    for (k = 0; k < sc.nstarts; k++) {
        struct start *s = &sc.starts[k];
        fmi2Status st = fmi2Error;
        if (s->kind == K_REAL) st = f.SetReal(c, &s->vr, 1, &s->x);
        else if (s->kind == K_INTEGER) { fmi2Integer i = (fmi2Integer)s->x; st = f.SetInteger(c, &s->vr, 1, &i); }
        else if (s->kind == K_BOOLEAN) { fmi2Boolean b = s->x != 0; st = f.SetBoolean(c, &s->vr, 1, &b); }
        else { fmi2String p = s->s; st = f.SetString(c, &s->vr, 1, &p); }
        CHECK(st == fmi2OK, "start value of vr %u: %s", s->vr, last_error);
    }
}

static fmi2Component start_instance(const char *name, fmi2Type type) {
    fmi2Component c = f.Instantiate(name, type, guid, resources, &callbacks, fmi2False, fmi2False);
    CHECK(c != NULL, "fmi2Instantiate %s: %s", name, last_error);
    if (!c) exit(1);
    apply_starts(c);
    set_inputs(c, 0.0);
    CHECK(f.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, sc.stop_time) == fmi2OK, "setup: %s", last_error);
    CHECK(f.EnterInitializationMode(c) == fmi2OK, "enter initialization: %s", last_error);
    CHECK(f.ExitInitializationMode(c) == fmi2OK, "exit initialization: %s", last_error);
    return c;
}

static long n_steps(void) { return (long)floor(sc.stop_time / sc.dt + 0.5); }

static void header(FILE *out) {
    int j;
    fprintf(out, "time");
    for (j = 0; j < sc.nout; j++) fprintf(out, ",%s", sc.out_name[j]);
    fprintf(out, "\n");
}

static void row(FILE *out, double t, const double *y) {
    int j;
    fprintf(out, "%.17g", t);
    for (j = 0; j < sc.nout; j++) fprintf(out, ",%.17g", y[j]);
    fprintf(out, "\n");
}

/* Co-Simulation steps k0..k1-1 of instance c (time k dt); the outputs after each into y (rows of
 * nout) when y is given and into out when given. */
static void cs_steps(fmi2Component c, long k0, long k1, double *y, FILE *out) {
    long k;
    double yk[MAXV];
    for (k = k0; k < k1; k++) {
        double t = k * sc.dt;
        set_inputs(c, t);
        if (f.DoStep(c, t, sc.dt, fmi2True) != fmi2OK) {
            CHECK(0, "fmi2DoStep at t = %.17g: %s", t, last_error);
            return;
        }
        CHECK(f.GetReal(c, sc.out_vr, sc.nout, yk) == fmi2OK, "outputs: %s", last_error);
        if (y) memcpy(y + (k - k0) * sc.nout, yk, sizeof(double) * sc.nout);
        if (out) row(out, (k + 1) * sc.dt, yk);
    }
}

static int run_cs(const char *csv) {
    FILE *out = fopen(csv, "w");
    fmi2Component c = start_instance("cs", fmi2CoSimulation);
    double y0[MAXV];
    header(out);
    CHECK(f.GetReal(c, sc.out_vr, sc.nout, y0) == fmi2OK, "initial outputs");
    row(out, 0.0, y0);
    cs_steps(c, 0, n_steps(), NULL, out);
    CHECK(f.Terminate(c) == fmi2OK, "terminate");
    f.FreeInstance(c);
    fclose(out);
    return failures;
}

/* ---- Model Exchange: classical RK4 with a fixed step, events where an indicator changes sign --- */

static void me_rhs(fmi2Component c, double t, const double *x, double *dx) {
    CHECK(f.SetTime(c, t) == fmi2OK, "fmi2SetTime");
    CHECK(f.SetContinuousStates(c, x, sc.nx) == fmi2OK, "fmi2SetContinuousStates: %s", last_error);
    CHECK(f.GetDerivatives(c, dx, sc.nx) == fmi2OK, "fmi2GetDerivatives at t = %g: %s", t, last_error);
}

static int run_me(const char *csv) {
    FILE *out = fopen(csv, "w");
    fmi2Component c = start_instance("me", fmi2ModelExchange);
    fmi2EventInfo info;
    double x[MAXX], k1[MAXX], k2[MAXX], k3[MAXX], k4[MAXX], xs[MAXX], z[MAXZ], z0[MAXZ], y[MAXV];
    double h = sc.me_step;
    long per = (long)floor(sc.dt / h + 0.5), steps = n_steps() * per, k, events = 0;
    int i, nx = sc.nx;
    fmi2Boolean enter = fmi2False, stop = fmi2False;
    if (nx > MAXX || sc.nz > MAXZ) { fprintf(stderr, "fmi_master: nx or nz too large\n"); return 2; }
    header(out);
    CHECK(f.NewDiscreteStates(c, &info) == fmi2OK, "initial event iteration");
    CHECK(f.EnterContinuousTimeMode(c) == fmi2OK, "continuous-time mode");
    CHECK(f.GetContinuousStates(c, x, nx) == fmi2OK, "states");
    CHECK(f.GetEventIndicators(c, z0, sc.nz) == fmi2OK, "indicators");
    CHECK(f.GetReal(c, sc.out_vr, sc.nout, y) == fmi2OK, "outputs");
    row(out, 0.0, y);
    for (k = 0; k < steps && !failures; k++) {
        double t = k * h;
        me_rhs(c, t, x, k1);
        for (i = 0; i < nx; i++) xs[i] = x[i] + 0.5 * h * k1[i];
        me_rhs(c, t + 0.5 * h, xs, k2);
        for (i = 0; i < nx; i++) xs[i] = x[i] + 0.5 * h * k2[i];
        me_rhs(c, t + 0.5 * h, xs, k3);
        for (i = 0; i < nx; i++) xs[i] = x[i] + h * k3[i];
        me_rhs(c, t + h, xs, k4);
        for (i = 0; i < nx; i++) x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        t = (k + 1) * h;
        CHECK(f.SetTime(c, t) == fmi2OK, "time");
        CHECK(f.SetContinuousStates(c, x, nx) == fmi2OK, "states at t = %g: %s", t, last_error);
        CHECK(f.GetEventIndicators(c, z, sc.nz) == fmi2OK, "indicators");
        for (i = 0; i < sc.nz; i++)
            if ((z[i] > 0) != (z0[i] > 0)) break;
        CHECK(f.CompletedIntegratorStep(c, fmi2True, &enter, &stop) == fmi2OK && !stop, "completed step");
        if (i < sc.nz || enter) {
            events++;
            CHECK(f.EnterEventMode(c) == fmi2OK, "event mode");
            do {
                CHECK(f.NewDiscreteStates(c, &info) == fmi2OK, "event at t = %g: %s", t, last_error);
            } while (info.newDiscreteStatesNeeded && !failures);
            CHECK(f.EnterContinuousTimeMode(c) == fmi2OK, "back to continuous time");
            if (info.valuesOfContinuousStatesChanged) f.GetContinuousStates(c, x, nx);
            f.GetEventIndicators(c, z, sc.nz);
        }
        memcpy(z0, z, sizeof(double) * sc.nz);
        if ((k + 1) % per == 0) {
            if (sc.nin) {
                set_inputs(c, t); /* held over the next output interval, as in Co-Simulation */
            }
            CHECK(f.GetReal(c, sc.out_vr, sc.nout, y) == fmi2OK, "outputs");
            for (i = 0; i < sc.nout; i++) CHECK(isfinite(y[i]), "output %s = %g at t = %g", sc.out_name[i], y[i], t);
            row(out, t, y);
        }
    }
    CHECK(events > 0, "no event");
    CHECK(f.Terminate(c) == fmi2OK, "terminate");
    f.FreeInstance(c);
    fclose(out);
    fprintf(stderr, "fmi_master: Model Exchange: %ld RK4 steps of %g s, %ld events\n", steps, h, events);
    return failures;
}

/* ---- FMU states ----------------------------------------------------------------------------- */

static char *serialize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    char *buf;
    CHECK(f.SerializedFMUstateSize(c, s, n) == fmi2OK && *n > 0, "serialized size");
    buf = malloc(*n);
    CHECK(f.SerializeFMUstate(c, s, buf, *n) == fmi2OK, "serialize: %s", last_error);
    return buf;
}

/* Half the scene on a; its state saved, serialized (written to blob_path); the second half on a;
 * then a rewound with fmi2SetFMUstate, and a fresh instance b from the deserialized blob: both
 * repeat the second half bit for bit. */
static int run_states(const char *blob_path) {
    long half = n_steps() / 2, rest = n_steps() - half;
    double *ya = malloc(sizeof(double) * rest * sc.nout), *yr = malloc(sizeof(double) * rest * sc.nout),
           *yb = malloc(sizeof(double) * rest * sc.nout), t2 = 0.0;
    fmi2Component a = start_instance("a", fmi2CoSimulation), b;
    fmi2FMUstate s = NULL, s2 = NULL;
    size_t n = 0;
    char *blob;
    FILE *out;
    cs_steps(a, 0, half, NULL, NULL);
    CHECK(f.GetFMUstate(a, &s) == fmi2OK && s, "fmi2GetFMUstate");
    blob = serialize(a, s, &n);
    out = fopen(blob_path, "wb");
    CHECK(out && fwrite(blob, 1, n, out) == n, "writing %s", blob_path);
    if (out) fclose(out);
    cs_steps(a, half, n_steps(), ya, NULL);
    CHECK(f.SetFMUstate(a, s) == fmi2OK, "fmi2SetFMUstate: %s", last_error);
    CHECK(f.GetRealStatus(a, fmi2LastSuccessfulTime, &t2) == fmi2OK && t2 == half * sc.dt,
          "time after the rewind: %.17g", t2);
    cs_steps(a, half, n_steps(), yr, NULL);
    CHECK(memcmp(ya, yr, sizeof(double) * rest * sc.nout) == 0, "the rewound run differs");
    b = f.Instantiate("b", fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False);
    CHECK(b != NULL, "instantiate b");
    CHECK(f.DeSerializeFMUstate(b, blob, n, &s2) == fmi2OK && s2, "fmi2DeSerializeFMUstate: %s", last_error);
    CHECK(f.SetFMUstate(b, s2) == fmi2OK, "set the deserialized state on a fresh instance: %s", last_error);
    cs_steps(b, half, n_steps(), yb, NULL);
    CHECK(memcmp(ya, yb, sizeof(double) * rest * sc.nout) == 0, "the deserialized run differs");
    /* Damaged blobs and foreign pointers are refused with fmi2Error and a message. */
    last_error[0] = 0;
    CHECK(f.DeSerializeFMUstate(b, blob, n / 2, &s2) == fmi2Error && last_error[0], "truncated blob");
    CHECK(f.Reset(b) == fmi2OK, "reset b");
    CHECK(f.FreeFMUstate(a, &s) == fmi2OK && s == NULL, "free a's state");
    CHECK(f.FreeFMUstate(b, &s2) == fmi2OK, "free b's state");
    f.FreeInstance(a);
    f.FreeInstance(b);
    free(blob); free(ya); free(yr); free(yb);
    fprintf(stderr, "fmi_master: FMU states: %lu bytes, rewind and deserialized copy bit-identical over %ld steps\n",
            (unsigned long)n, rest);
    return failures;
}

/* The second half of the scene from a blob serialized by another binary (the Linux .so's blob in
 * the Windows DLL, and the other way round). */
static int run_blob(const char *blob_path, const char *csv) {
    long half = n_steps() / 2;
    fmi2Component b = f.Instantiate("b", fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False);
    fmi2FMUstate s = NULL;
    FILE *in = fopen(blob_path, "rb"), *out = fopen(csv, "w");
    char *blob;
    long n;
    if (!in || !out) { fprintf(stderr, "fmi_master: cannot open %s or %s\n", blob_path, csv); return 2; }
    fseek(in, 0, SEEK_END);
    n = ftell(in);
    fseek(in, 0, SEEK_SET);
    blob = malloc(n);
    CHECK(fread(blob, 1, n, in) == (size_t)n, "reading the blob");
    fclose(in);
    CHECK(f.DeSerializeFMUstate(b, blob, n, &s) == fmi2OK && s, "deserialize a foreign blob: %s", last_error);
    CHECK(f.SetFMUstate(b, s) == fmi2OK, "set it: %s", last_error);
    header(out);
    if (!failures) cs_steps(b, half, n_steps(), NULL, out);
    f.FreeFMUstate(b, &s);
    f.FreeInstance(b);
    fclose(out);
    free(blob);
    return failures;
}

/* ---- two instances in two threads ----------------------------------------------------------- */

struct job {
    const char *name;
    double *y;
};

#ifdef _WIN32
static DWORD WINAPI thread_main(LPVOID arg)
#else
static void *thread_main(void *arg)
#endif
{
    struct job *j = arg;
    fmi2Component c = start_instance(j->name, fmi2CoSimulation);
    cs_steps(c, 0, n_steps(), j->y, NULL);
    f.Terminate(c);
    f.FreeInstance(c);
    return 0;
}

/* The sequential run is a thread of its own too: on Windows a new thread starts with the x87
 * control word 0x27f (53-bit precision) whatever the main thread's (MinGW's startup sets
 * 0x37f), and MinGW's exp/pow/log/sin/cos/atan2 in the DLL use the x87 unit. */
static int run_threads(void) {
    size_t size = sizeof(double) * n_steps() * sc.nout;
    struct job seq = {"seq", malloc(size)}, t1 = {"t1", malloc(size)}, t2 = {"t2", malloc(size)};
#ifdef _WIN32
    {
        HANDLE h[2];
        h[0] = CreateThread(NULL, 0, thread_main, &seq, 0, NULL);
        CHECK(h[0] != NULL, "CreateThread");
        WaitForSingleObject(h[0], INFINITE);
        CloseHandle(h[0]);
        h[0] = CreateThread(NULL, 0, thread_main, &t1, 0, NULL);
        h[1] = CreateThread(NULL, 0, thread_main, &t2, 0, NULL);
        CHECK(h[0] && h[1], "CreateThread");
        WaitForMultipleObjects(2, h, TRUE, INFINITE);
        CloseHandle(h[0]);
        CloseHandle(h[1]);
    }
#else
    {
        pthread_t h[2];
        CHECK(pthread_create(&h[0], NULL, thread_main, &seq) == 0, "pthread_create");
        pthread_join(h[0], NULL);
        CHECK(pthread_create(&h[0], NULL, thread_main, &t1) == 0, "pthread_create");
        CHECK(pthread_create(&h[1], NULL, thread_main, &t2) == 0, "pthread_create");
        pthread_join(h[0], NULL);
        pthread_join(h[1], NULL);
    }
#endif
    {
        long n = n_steps() * sc.nout, i1 = 0, i2 = 0;
        double d1 = 0.0, d2 = 0.0;
        for (i1 = 0; i1 < n && seq.y[i1] == t1.y[i1]; i1++) {}
        for (i2 = 0; i2 < n && seq.y[i2] == t2.y[i2]; i2++) {}
        for (long i = 0; i < n; i++) {
            d1 = fmax(d1, fabs(seq.y[i] - t1.y[i]) / fmax(fabs(seq.y[i]), 1e-300));
            d2 = fmax(d2, fabs(seq.y[i] - t2.y[i]) / fmax(fabs(seq.y[i]), 1e-300));
        }
        CHECK(i1 == n, "thread 1 differs from the sequential run from step %ld (max relative %g)", i1 / sc.nout, d1);
        CHECK(i2 == n, "thread 2 differs from the sequential run from step %ld (max relative %g)", i2 / sc.nout, d2);
        CHECK(memcmp(t1.y, t2.y, size) == 0, "the two threads differ from each other");
    }
    fprintf(stderr, "fmi_master: two instances in two threads: bit-identical to the sequential run (%ld steps)\n",
            n_steps());
    free(seq.y); free(t1.y); free(t2.y);
    return failures;
}

/* ---- bad input: the reliability suite's cases (tests/fmi_reliability.rs) through the DLL ------ */

/* SpurGearMesh's value references (modelDescription/variables.toml; tools/windows.sh checks
 * them against the packaged modelDescription.xml). */
enum {
    VR_GEOMETRY = 1, VR_ZA = 4, VR_ZB = 5, VR_J_A = 18, VR_CHI = 21, VR_SOLVER = 30, VR_TAU_A = 40,
    VR_W_A = 52, VR_DTE = 54, VR_S_B = 85, VR_PITCH_A = 119, VR_PITCH_B = 120
};

static fmi2Component quiet(void) {
    return f.Instantiate("q", fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False);
}

static fmi2Component running(void) {
    fmi2Component c = quiet();
    f.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
    f.EnterInitializationMode(c);
    f.ExitInitializationMode(c);
    return c;
}

static int cases = 0;

static void expect(fmi2Component c, fmi2Status got, fmi2Status want, const char *what, const char *keyword) {
    cases++;
    CHECK(got == want, "%s: status %d, expected %d", what, (int)got, (int)want);
    CHECK(strstr(last_error, keyword) != NULL, "%s: the logged message '%s' lacks '%s'", what, last_error, keyword);
    if (verbose) fprintf(stderr, "  %-40s -> %d %s\n", what, (int)got, last_error);
    f.FreeInstance(c);
    last_error[0] = 0;
}

static int run_errors(void) {
    fmi2Component c;
    fmi2Real x = 0.0, nan = NAN, inf = INFINITY;
    fmi2Integer i;
    fmi2ValueReference vr;
    fmi2FMUstate s = NULL, s2 = NULL;
    fmi2String p;
    size_t n;
    char *blob;
    int t;
    last_error[0] = 0;
    /* Instantiation: refused with NULL and a message. */
    CHECK(f.Instantiate("x", fmi2CoSimulation, "{wrong}", "", &callbacks, fmi2False, fmi2False) == NULL &&
              strstr(last_error, "GUID"), "wrong GUID: %s", last_error);
    CHECK(f.Instantiate("x", (fmi2Type)7, guid, "", &callbacks, fmi2False, fmi2False) == NULL &&
              strstr(last_error, "fmuType"), "bad fmuType: %s", last_error);
    CHECK(f.Instantiate(NULL, fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False) == NULL &&
              strstr(last_error, "instanceName"), "no instance name: %s", last_error);
    cases += 3;
    /* The state machine. */
    c = quiet(); expect(c, f.DoStep(c, 0.0, 1e-4, fmi2True), fmi2Error, "step before initialization", "not allowed");
    c = quiet(); expect(c, f.ExitInitializationMode(c), fmi2Error, "exit without enter", "not allowed");
    c = running(); expect(c, f.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2Error, "setup after initialization", "not allowed");
    c = running(); expect(c, f.EnterInitializationMode(c), fmi2Error, "enter twice", "not allowed");
    c = quiet(); expect(c, f.Terminate(c), fmi2Error, "terminate before initialization", "not allowed");
    vr = VR_TAU_A;
    c = quiet(); expect(c, f.GetReal(c, &vr, 1, &x), fmi2Error, "get before initialization", "not allowed");
    c = running(); f.Terminate(c); x = 1.0;
    expect(c, f.SetReal(c, &vr, 1, &x), fmi2Error, "set after terminate", "not allowed");
    /* Arguments. */
    c = quiet(); expect(c, f.SetupExperiment(c, fmi2True, 0.5, 0.0, fmi2False, 0.0), fmi2Error, "tolerance out of range", "tolerance");
    c = quiet(); expect(c, f.SetupExperiment(c, fmi2False, 0.0, nan, fmi2False, 0.0), fmi2Error, "start time NaN", "startTime");
    c = quiet(); expect(c, f.SetupExperiment(c, fmi2False, 0.0, 1.0, fmi2True, 0.5), fmi2Error, "stop before start", "stopTime");
    vr = 9999;
    c = running(); expect(c, f.GetReal(c, &vr, 1, &x), fmi2Error, "unknown value reference (get)", "unknown value reference");
    vr = VR_ZA;
    c = running(); expect(c, f.GetReal(c, &vr, 1, &x), fmi2Error, "wrong type (get)", "Integer");
    vr = VR_W_A;
    c = running(); expect(c, f.GetReal(c, &vr, 1, NULL), fmi2Error, "null value array", "null pointer");
    vr = 9999; x = 1.0;
    c = quiet(); expect(c, f.SetReal(c, &vr, 1, &x), fmi2Error, "unknown value reference (set)", "unknown value reference");
    vr = VR_W_A;
    c = running(); expect(c, f.SetReal(c, &vr, 1, &x), fmi2Error, "set an output", "cannot be set");
    vr = VR_S_B;
    c = quiet(); expect(c, f.SetReal(c, &vr, 1, &x), fmi2Error, "set a calculated parameter", "cannot be set");
    vr = VR_J_A;
    c = running(); expect(c, f.SetReal(c, &vr, 1, &x), fmi2Error, "fixed parameter after initialization", "fixed");
    vr = VR_TAU_A;
    c = running(); expect(c, f.SetReal(c, &vr, 1, &nan), fmi2Error, "NaN input", "finite");
    vr = VR_CHI;
    c = quiet(); expect(c, f.SetReal(c, &vr, 1, &inf), fmi2Error, "infinite parameter", "finite");
    x = -1.0;
    c = quiet(); expect(c, f.SetReal(c, &vr, 1, &x), fmi2Error, "negative damping", "chi");
    vr = VR_TAU_A; i = 1;
    c = quiet(); expect(c, f.SetInteger(c, &vr, 1, &i), fmi2Error, "wrong type (set)", "Real");
    vr = VR_SOLVER; i = 7;
    c = quiet(); expect(c, f.SetInteger(c, &vr, 1, &i), fmi2Error, "invalid integer parameter", "solver");
    vr = VR_PITCH_A; p = "1e-7, x";
    c = quiet(); expect(c, f.SetString(c, &vr, 1, &p), fmi2Error, "pitch errors that are not numbers", "entry 2 ('x') is not a number");
    vr = VR_PITCH_B; p = "1e-7, 2e-7";
    c = quiet();
    CHECK(f.SetString(c, &vr, 1, &p) == fmi2OK, "two pitch errors");
    f.EnterInitializationMode(c);
    expect(c, f.ExitInitializationMode(c), fmi2Error, "pitch errors, one per tooth", "2 entries, but the wheel has 33 teeth");
    vr = VR_ZB; i = 34;
    c = quiet(); f.SetInteger(c, &vr, 1, &i); f.EnterInitializationMode(c);
    expect(c, f.ExitInitializationMode(c), fmi2Error, "inconsistent parameters at initialization", "zB");
    /* Steps. */
    c = running(); expect(c, f.DoStep(c, 0.0, -1e-4, fmi2True), fmi2Error, "negative step", "communicationStepSize");
    c = running(); expect(c, f.DoStep(c, 0.0, nan, fmi2True), fmi2Error, "NaN step", "must be finite");
    c = running(); expect(c, f.DoStep(c, 1.0, 1e-4, fmi2True), fmi2Error, "wrong time", "does not match");
    c = quiet(); f.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, 0.1); f.EnterInitializationMode(c);
    f.ExitInitializationMode(c);
    expect(c, f.DoStep(c, 0.0, 0.2, fmi2True), fmi2Error, "past the stop time", "stopTime");
    {
        fmi2Status st = fmi2OK;
        double tt = 0.0;
        c = running(); vr = VR_TAU_A; x = 1e9; f.SetReal(c, &vr, 1, &x);
        for (t = 0; st == fmi2OK && t < 100; t++, tt += 1e-4) st = f.DoStep(c, tt, 1e-4, fmi2True);
        expect(c, st, fmi2Error, "contact law out of range", "out of the model's range");
    }
    {
        fmi2ValueReference vrs[2] = {27, 28};
        fmi2Real w[2] = {1e5, 1e5 / 1.5};
        c = quiet(); f.SetReal(c, vrs, 2, w); f.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
        f.EnterInitializationMode(c); f.ExitInitializationMode(c);
        expect(c, f.DoStep(c, 0.0, 1.0, fmi2True), fmi2Discard, "work cap of a step", "work cap");
    }
    c = running(); expect(c, f.CancelStep(c), fmi2Error, "cancel", "no step to cancel");
    c = running(); expect(c, f.GetRealStatus(c, (fmi2StatusKind)99, &x), fmi2Error, "unknown status kind", "fmi2StatusKind");
    /* FMU states. */
    c = running(); expect(c, f.GetFMUstate(c, NULL), fmi2Error, "null FMUstate argument", "null");
    c = running(); s = (fmi2FMUstate)(size_t)0x1234;
    expect(c, f.SetFMUstate(c, s), fmi2Error, "bogus FMU state", "not created by this instance");
    c = running(); s = NULL; f.GetFMUstate(c, &s); s2 = s; f.FreeFMUstate(c, &s);
    expect(c, f.SetFMUstate(c, s2), fmi2Error, "freed FMU state", "already freed");
    {
        fmi2Component other = running();
        s = NULL; f.GetFMUstate(other, &s); s2 = s;
        c = running(); expect(c, f.FreeFMUstate(c, &s2), fmi2Error, "state of another instance", "not created by this instance");
        f.FreeFMUstate(other, &s);
        f.FreeInstance(other);
    }
    c = running(); s = NULL; f.GetFMUstate(c, &s);
    expect(c, f.SerializedFMUstateSize(c, s, NULL), fmi2Error, "size without a pointer", "null pointer");
    c = running(); s = NULL; f.GetFMUstate(c, &s); blob = serialize(c, s, &n);
    expect(c, f.SerializeFMUstate(c, s, blob, n - 1), fmi2Error, "buffer too small", "too small");
    c = running(); blob[n - 20] ^= 0x40;
    expect(c, f.DeSerializeFMUstate(c, blob, n, &s2), fmi2Error, "damaged blob", "rejected");
    free(blob);
    /* Logging. */
    {
        const char *cat[] = {"logEverything"};
        c = running(); expect(c, f.SetDebugLogging(c, fmi2True, 1, cat), fmi2Error, "unknown log category", "unknown log category");
        c = running(); expect(c, f.SetDebugLogging(c, fmi2True, 1, NULL), fmi2Error, "categories: null array", "null pointer");
    }
    /* After an error the instance is usable again after fmi2Reset (no panic, no crash). */
    c = running(); vr = 9999;
    CHECK(f.GetReal(c, &vr, 1, &x) == fmi2Error, "error");
    CHECK(f.Reset(c) == fmi2OK, "reset after an error");
    f.SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
    f.EnterInitializationMode(c);
    CHECK(f.ExitInitializationMode(c) == fmi2OK, "initialization after the reset");
    CHECK(f.DoStep(c, 0.0, 1e-3, fmi2True) == fmi2OK, "a step after the reset: %s", last_error);
    f.FreeInstance(c);
    CHECK(strstr(last_error, "panic") == NULL, "a panic was caught: %s", last_error);
    fprintf(stderr, "fmi_master: %d bad-input cases, each fmi2Error/fmi2Discard with its message through the logger\n", cases);
    return failures;
}

int main(int argc, char **argv) {
    void *lib;
    const char *mode;
    int rc;
    if (argc < 4) {
        fprintf(stderr, "usage: %s <library> <guid> cs|me|states|threads|errors|blob [scene.txt] [out]\n", argv[0]);
        return 2;
    }
    guid = argv[2];
    mode = argv[3];
    verbose = getenv("FMI_MASTER_VERBOSE") != NULL;
    if (getenv("FMI_MASTER_RESOURCES")) resources = getenv("FMI_MASTER_RESOURCES");
#if defined(_WIN32) && (defined(__x86_64__) || defined(__i386__))
    /* FMI_MASTER_X87=53: the x87 control word of a thread Windows creates and of an MSVC-built
     * master, 0x27f (53-bit precision), instead of MinGW's 0x37f (64-bit) on the main thread. The
     * DLL's exp/pow/log/sin/cos/atan2 come from MinGW's runtime and run on the x87 unit, so
     * their last bits depend on it (docs/platforms.md, "How close Windows is to Linux, and why"). */
    {
        const char *x87 = getenv("FMI_MASTER_X87");
        unsigned short cw;
        if (x87 && !strcmp(x87, "53")) {
            cw = 0x27f;
            __asm__ volatile("fldcw %0" : : "m"(cw));
        }
        __asm__ volatile("fnstcw %0" : "=m"(cw));
        if (verbose) fprintf(stderr, "fmi_master: x87 control word %#x\n", cw);
    }
#endif
    lib = load(argv[1]);
#define LOAD(name) f.name = (fmi2##name##TYPE *)sym(lib, "fmi2" #name)
    LOAD(Instantiate); LOAD(FreeInstance); LOAD(SetDebugLogging); LOAD(SetupExperiment);
    LOAD(EnterInitializationMode); LOAD(ExitInitializationMode); LOAD(Terminate); LOAD(Reset);
    LOAD(GetReal); LOAD(SetReal); LOAD(SetInteger); LOAD(SetBoolean); LOAD(SetString);
    LOAD(GetFMUstate); LOAD(SetFMUstate); LOAD(FreeFMUstate); LOAD(SerializedFMUstateSize);
    LOAD(SerializeFMUstate); LOAD(DeSerializeFMUstate); LOAD(DoStep); LOAD(GetRealStatus);
    LOAD(CancelStep);
    if (!strcmp(mode, "me")) {
        LOAD(EnterEventMode); LOAD(NewDiscreteStates); LOAD(EnterContinuousTimeMode);
        LOAD(CompletedIntegratorStep); LOAD(SetTime); LOAD(SetContinuousStates);
        LOAD(GetDerivatives); LOAD(GetEventIndicators); LOAD(GetContinuousStates);
    }
    if (argc > 4) read_scene(argv[4]);
    if (!strcmp(mode, "cs") && argc > 5) rc = run_cs(argv[5]);
    else if (!strcmp(mode, "me") && argc > 5) rc = run_me(argv[5]);
    else if (!strcmp(mode, "states") && argc > 5) rc = run_states(argv[5]);
    else if (!strcmp(mode, "blob") && argc > 6) rc = run_blob(argv[5], argv[6]);
    else if (!strcmp(mode, "threads") && argc > 4) rc = run_threads();
    else if (!strcmp(mode, "errors")) rc = run_errors();
    else {
        fprintf(stderr, "fmi_master: unknown mode or missing arguments\n");
        return 2;
    }
    unload(lib);
    fprintf(stderr, "fmi_master %s: %ld log messages (%ld errors), %d failures\n", mode, messages, error_messages,
            failures);
    return rc ? 1 : 0;
}
