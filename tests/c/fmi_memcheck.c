/* A full simulation through the C API of the FMU's shared library, as a C master runs it: the
 * program behind the valgrind (memcheck) run of issue 5 (tools/reliability.sh).
 *
 *   fmi_memcheck <SpurGearMesh.so> <guid> [steps]
 *
 * Loads the library with dlopen, resolves every function with the types of the standard's
 * fmi2FunctionTypes.h, and runs: instantiation (also failed ones), debug logging, two instances,
 * initialization of the running paper scene, `steps` communication steps of 1e-4 s with the
 * outputs read and checked after every step, FMU states every 500 steps (get, size, serialize,
 * deserialize into the other instance, set, continue both bit-identically, overwrite in place,
 * free), error paths (unknown value reference, unknown log category, wrong time, bogus and
 * freed FMU-state pointers, truncated and corrupted blobs, calls in the wrong state), recovery
 * with fmi2SetFMUstate and fmi2Reset, terminate and free, including an instance freed with FMU
 * states still allocated. Then Model Exchange (explicit Euler with the events the indicators
 * show, FMU states in continuous-time mode, bad sizes and values) and FMI 3.0 (Co-Simulation
 * with time and an event indicator read as variables, FMU states; Model Exchange steps) through
 * the same library. Exits 0 if every check passed. The FMI 2.0 logger is a real C-variadic
 * function that formats the message printf-style (so the FMU's %% escaping is exercised).
 *
 * The value references are those of modelDescription/variables.toml; tools/reliability.sh
 * checks them against the packaged modelDescription.xml before running this.
 */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"

enum {
    VR_CHI = 21, VR_C_LOAD = 24, VR_W_A_START = 27, VR_W_B_START = 28, VR_TAU_A = 40,
    VR_W_A = 52, VR_W_B = 53, VR_DTE = 54,
    VR_S_F1 = 66, VR_S_F2 = 67, VR_S_B1 = 68, VR_S_B2 = 69,
    VR_S_B = 85, VR_BASE_PITCH = 89,
    /* The internal pair (planetary.md section 1). */
    VR_GEOMETRY = 1, VR_ZA = 4, VR_ZB = 5, VR_MODULE = 8, VR_XB = 11, VR_WIDTH = 13, VR_J_A = 18,
    VR_J_B = 19, VR_BACKLASH = 20, VR_MU = 22, VR_INTERNAL = 48
};

static int failures = 0;
static long messages = 0, error_messages = 0;
static int verbose = 0;

#define CHECK(cond, ...)                                                   \
    do {                                                                   \
        if (!(cond)) {                                                     \
            fprintf(stderr, "fmi_memcheck: line %d: ", __LINE__);          \
            fprintf(stderr, __VA_ARGS__);                                  \
            fprintf(stderr, "\n");                                         \
            failures++;                                                    \
        }                                                                  \
    } while (0)

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    char text[2048];
    va_list ap;
    (void)env;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message, ap);
    va_end(ap);
    messages++;
    if (status >= fmi2Discard) error_messages++;
    if (verbose || status == fmi2Fatal)
        fprintf(stderr, "[%s %d %s] %s\n", instance, (int)status, category, text);
}

struct api {
    fmi2GetVersionTYPE *GetVersion;
    fmi2GetTypesPlatformTYPE *GetTypesPlatform;
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
    fmi2GetIntegerTYPE *GetInteger;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *DeSerializeFMUstate;
    fmi2DoStepTYPE *DoStep;
    fmi2GetRealStatusTYPE *GetRealStatus;
    fmi2GetStatusTYPE *GetStatus;
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
    fmi2GetNominalsOfContinuousStatesTYPE *GetNominalsOfContinuousStates;
    fmi2GetDirectionalDerivativeTYPE *GetDirectionalDerivative;
};

static void *sym(void *lib, const char *name) {
    void *p = dlsym(lib, name);
    if (!p) {
        fprintf(stderr, "fmi_memcheck: %s is not exported\n", name);
        exit(2);
    }
    return p;
}

static const fmi2ValueReference outputs[] = {VR_W_A, VR_W_B, VR_DTE, VR_S_F1, VR_S_F2, VR_S_B1, VR_S_B2};
#define N_OUT (sizeof outputs / sizeof outputs[0])

static void init_paper_scene(const struct api *f, fmi2Component c) {
    const fmi2ValueReference vr[] = {VR_TAU_A, VR_C_LOAD, VR_W_A_START, VR_W_B_START, VR_CHI};
    const fmi2Real v[] = {100.0, 2.0, 100.0, 100.0 / 1.5, 10.0};
    CHECK(f->SetReal(c, vr, 5, v) == fmi2OK, "set the paper scene");
    CHECK(f->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup");
    CHECK(f->EnterInitializationMode(c) == fmi2OK, "enter initialization");
    CHECK(f->ExitInitializationMode(c) == fmi2OK, "exit initialization");
}

/* Serializes an FMU state of c into a malloc'ed buffer. */
static char *serialize(const struct api *f, fmi2Component c, fmi2FMUstate s, size_t *n) {
    char *buf;
    CHECK(f->SerializedFMUstateSize(c, s, n) == fmi2OK && *n > 0, "serialized size");
    buf = malloc(*n);
    CHECK(f->SerializeFMUstate(c, s, buf, *n) == fmi2OK, "serialize");
    return buf;
}


#define NX 8
#define NZ 32

/* Model Exchange: explicit Euler (2 ms in steps of 1e-6 s, stable on the damped paper rig),
 * with event mode whenever an indicator changes sign, FMU states in continuous-time mode, and
 * bad sizes and values on a second instance. */
/* A pinion in a ring (docs/internal-pair.md's worked pair, scenes/internal-damped.toml) with tooth counts
 * zA/zB and profile shift xB; returns the status of fmi2ExitInitializationMode. */
static fmi2Status init_ring(void *lib, const struct api *f, fmi2Component c, int za, int zb, fmi2Real xb) {
    fmi2SetIntegerTYPE *set_int = (fmi2SetIntegerTYPE *)sym(lib, "fmi2SetInteger");
    fmi2SetBooleanTYPE *set_bool = (fmi2SetBooleanTYPE *)sym(lib, "fmi2SetBoolean");
    const fmi2ValueReference ivr[] = {VR_GEOMETRY, VR_ZA, VR_ZB}, bvr[] = {VR_INTERNAL};
    const fmi2Integer iv[] = {2, za, zb};
    const fmi2Boolean bv[] = {fmi2True};
    const fmi2ValueReference vr[] = {VR_MODULE, VR_XB, VR_WIDTH, VR_J_A, VR_J_B, VR_BACKLASH, VR_MU,
                                     VR_CHI, VR_TAU_A, VR_C_LOAD, VR_W_A_START, VR_W_B_START};
    const fmi2Real v[] = {0.002, xb, 0.02, 5e-3, 0.5, 5e-5, 0.05, 20.0, 20.0, 3.0, 60.0, 20.0};
    CHECK(set_int(c, ivr, 3, iv) == fmi2OK, "set the ring's integers");
    CHECK(set_bool(c, bvr, 1, bv) == fmi2OK, "set internal");
    CHECK(f->SetReal(c, vr, 12, v) == fmi2OK, "set the ring's reals");
    CHECK(f->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup");
    CHECK(f->EnterInitializationMode(c) == fmi2OK, "enter initialization");
    return f->ExitInitializationMode(c);
}

/* The internal pair: refused geometry (the error path), then a run whose contact coordinates stay
 * in their windows, an FMU state taken and restored, and a reset back to the paper scene. */
static void internal_pair(void *lib, const struct api *f, const fmi2CallbackFunctions *cb, const char *guid,
                          long steps) {
    fmi2Component c = f->Instantiate("ring", fmi2CoSimulation, guid, "", cb, fmi2False, fmi2True);
    fmi2ValueReference geo_vr[] = {VR_S_B, VR_BASE_PITCH};
    fmi2Real t = 0.0, h = 5e-5, y[N_OUT], geo[2];
    fmi2FMUstate s = NULL;
    long k;
    CHECK(c != NULL, "instantiate the ring");
    if (!c) return;
    /* 36/38 with xB = 0.3: tip interference, refused at initialization. */
    CHECK(init_ring(lib, f, c, 36, 38, 0.3) == fmi2Error, "tip interference is refused");
    CHECK(f->Reset(c) == fmi2OK, "reset after the refusal");
    CHECK(init_ring(lib, f, c, 20, 60, 0.5) == fmi2OK, "the ring pair initializes");
    CHECK(f->GetReal(c, geo_vr, 2, geo) == fmi2OK, "s_b, base_pitch");
    for (k = 0; k < steps; k++, t += h) {
        unsigned i;
        CHECK(f->DoStep(c, t, h, fmi2True) == fmi2OK, "ring step %ld at t = %g", k, t);
        CHECK(f->GetReal(c, outputs, N_OUT, y) == fmi2OK, "ring outputs");
        for (i = 0; i < N_OUT; i++) CHECK(isfinite(y[i]), "ring output %u is %g", outputs[i], y[i]);
        for (i = 3; i < 7; i++)
            CHECK(y[i] >= geo[0] - 2 * geo[1] - 1e-9 && y[i] <= geo[0] + 1e-9,
                  "ring contact coordinate %u = %.17g outside its window at t = %g", outputs[i], y[i], t);
        if (k == steps / 2) CHECK(f->GetFMUstate(c, &s) == fmi2OK && s, "ring state");
    }
    CHECK(f->SetFMUstate(c, s) == fmi2OK, "restore the ring state");
    CHECK(f->FreeFMUstate(c, &s) == fmi2OK, "free the ring state");
    CHECK(f->Reset(c) == fmi2OK, "reset the ring");
    init_paper_scene(f, c);
    f->FreeInstance(c);
}

static void model_exchange(const struct api *f, const fmi2CallbackFunctions *cb, const char *guid) {
    fmi2Component c = f->Instantiate("me", fmi2ModelExchange, guid, "", cb, fmi2False, fmi2False);
    fmi2Component bad = f->Instantiate("me-bad", fmi2ModelExchange, guid, "", cb, fmi2False, fmi2False);
    fmi2EventInfo info;
    fmi2Real x[NX], dx[NX], z[NZ], z0[NZ], nom[NX], y[N_OUT], t = 0.0, h = 1e-6;
    fmi2Boolean enter = fmi2False, stop = fmi2False;
    fmi2FMUstate s = NULL, s2 = NULL;
    long k, events = 0;
    int i;
    char *blob;
    size_t n = 0;
    CHECK(c && bad, "instantiate Model Exchange");
    if (!c || !bad) return;
    init_paper_scene(f, c);
    CHECK(f->NewDiscreteStates(c, &info) == fmi2OK && !info.valuesOfContinuousStatesChanged, "initial event");
    CHECK(f->EnterContinuousTimeMode(c) == fmi2OK, "continuous-time mode");
    CHECK(f->GetContinuousStates(c, x, NX) == fmi2OK, "states");
    CHECK(f->GetNominalsOfContinuousStates(c, nom, NX) == fmi2OK, "nominals");
    CHECK(f->GetEventIndicators(c, z0, NZ) == fmi2OK, "indicators");
    for (k = 0; k < 2000; k++) {
        CHECK(f->GetDerivatives(c, dx, NX) == fmi2OK, "derivatives at t = %g", t);
        if (k % 500 == 0) {
            /* d(der(dte_rate))/d(dte) by the FMU's central differences: finite, and the
             * point left as it was. */
            const fmi2ValueReference unknown = 126, known = 54;
            const fmi2Real seed = 1.0;
            fmi2Real slope = 0.0, again[NX];
            CHECK(f->GetDirectionalDerivative(c, &unknown, 1, &known, 1, &seed, &slope) == fmi2OK
                  && slope <= 0.0, "directional derivative at t = %g", t);
            CHECK(f->GetDerivatives(c, again, NX) == fmi2OK
                  && memcmp(again, dx, sizeof again) == 0, "the point restored at t = %g", t);
        }
        for (i = 0; i < NX; i++) x[i] += h * dx[i];
        t += h;
        CHECK(f->SetTime(c, t) == fmi2OK, "time");
        CHECK(f->SetContinuousStates(c, x, NX) == fmi2OK, "set states");
        CHECK(f->GetEventIndicators(c, z, NZ) == fmi2OK, "indicators");
        for (i = 0; i < NZ; i++) {
            if ((z[i] > 0) != (z0[i] > 0)) break;
        }
        CHECK(f->CompletedIntegratorStep(c, fmi2True, &enter, &stop) == fmi2OK && !stop, "completed step");
        if (i < NZ || enter) {
            events++;
            CHECK(f->EnterEventMode(c) == fmi2OK, "event mode");
            CHECK(f->NewDiscreteStates(c, &info) == fmi2OK, "event at t = %g", t);
            CHECK(f->EnterContinuousTimeMode(c) == fmi2OK, "back to continuous time");
            if (info.valuesOfContinuousStatesChanged) f->GetContinuousStates(c, x, NX);
            f->GetEventIndicators(c, z, NZ);
        }
        memcpy(z0, z, sizeof z);
        CHECK(f->GetReal(c, outputs, N_OUT, y) == fmi2OK, "outputs");
        for (i = 0; i < (int)N_OUT; i++) CHECK(isfinite(y[i]), "output %u is %g", outputs[i], y[i]);
        if (k == 1000) {
            CHECK(f->GetFMUstate(c, &s) == fmi2OK, "get state");
            blob = serialize(f, c, s, &n);
            CHECK(f->DeSerializeFMUstate(c, blob, n, &s2) == fmi2OK, "deserialize");
            CHECK(f->SetFMUstate(c, s2) == fmi2OK, "set the deserialized state");
            free(blob);
            CHECK(f->FreeFMUstate(c, &s2) == fmi2OK, "free");
        }
    }
    CHECK(events > 0, "no event in 2 ms");
    CHECK(f->Terminate(c) == fmi2OK, "terminate");
    f->FreeFMUstate(c, &s);
    f->FreeInstance(c);

    init_paper_scene(f, bad);
    CHECK(f->DoStep(bad, 0.0, 1e-4, fmi2True) == fmi2Error, "fmi2DoStep in Model Exchange");
    CHECK(f->Reset(bad) == fmi2OK, "reset");
    init_paper_scene(f, bad);
    f->NewDiscreteStates(bad, &info);
    f->EnterContinuousTimeMode(bad);
    CHECK(f->GetContinuousStates(bad, x, NX - 1) == fmi2Error, "wrong nx");
    CHECK(f->Reset(bad) == fmi2OK, "reset");
    init_paper_scene(f, bad);
    f->NewDiscreteStates(bad, &info);
    f->EnterContinuousTimeMode(bad);
    x[1] = NAN;
    CHECK(f->SetContinuousStates(bad, x, NX) == fmi2Error, "NaN state");
    f->FreeInstance(bad);
}

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    messages++;
    if (status >= fmi3Discard) error_messages++;
    if (verbose || status == fmi3Fatal) fprintf(stderr, "[fmi3 %d %s] %s\n", (int)status, category, message);
}

/* FMI 3.0 through the same library: Co-Simulation with time and an event indicator read as
 * variables and an FMU state round trip, then Model Exchange steps. */
static void fmi3(void *lib, const char *token) {
#define LOAD3(name) fmi3##name##TYPE *name = (fmi3##name##TYPE *)sym(lib, "fmi3" #name)
    LOAD3(InstantiateCoSimulation); LOAD3(InstantiateModelExchange); LOAD3(FreeInstance);
    LOAD3(EnterInitializationMode); LOAD3(ExitInitializationMode); LOAD3(SetFloat64);
    LOAD3(GetFloat64); LOAD3(DoStep); LOAD3(Terminate); LOAD3(GetFMUState); LOAD3(SetFMUState);
    LOAD3(FreeFMUState); LOAD3(SerializedFMUStateSize); LOAD3(SerializeFMUState);
    LOAD3(DeserializeFMUState); LOAD3(UpdateDiscreteStates); LOAD3(EnterContinuousTimeMode);
    LOAD3(GetNumberOfContinuousStates); LOAD3(GetContinuousStateDerivatives);
    LOAD3(GetContinuousStates); LOAD3(SetContinuousStates); LOAD3(SetTime);
    LOAD3(CompletedIntegratorStep); LOAD3(GetVersion);
    const fmi3ValueReference vr[] = {VR_TAU_A, VR_C_LOAD, VR_W_A_START, VR_W_B_START, VR_CHI};
    const fmi3Float64 v[] = {100.0, 2.0, 100.0, 100.0 / 1.5, 10.0};
    const fmi3ValueReference read[] = {0, VR_DTE, 1001};
    fmi3Float64 y[3], t = 0.0, h = 1e-4, last = 0.0, x[NX], dx[NX];
    fmi3Boolean event = fmi3False, stop = fmi3False, early = fmi3False, b[4];
    fmi3FMUState s = NULL, s2 = NULL;
    fmi3Byte *blob;
    size_t n = 0, nx = 0;
    long k;
    int i;
    fmi3Instance c;
    CHECK(strcmp(GetVersion(), "3.0") == 0, "fmi3 version");
    c = InstantiateCoSimulation("cs3", token, "", fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0,
                                NULL, logger3, NULL);
    CHECK(c != NULL, "fmi3 Co-Simulation");
    if (!c) return;
    CHECK(SetFloat64(c, vr, 5, v, 5) == fmi3OK, "start values");
    CHECK(EnterInitializationMode(c, fmi3True, 1e-6, 0.0, fmi3False, 0.0) == fmi3OK, "initialization");
    CHECK(ExitInitializationMode(c) == fmi3OK, "exit initialization");
    for (k = 0; k < 500; k++, t += h) {
        CHECK(DoStep(c, t, h, fmi3True, &event, &stop, &early, &last) == fmi3OK && !event && !stop && !early,
              "fmi3DoStep at %g", t);
        CHECK(GetFloat64(c, read, 3, y, 3) == fmi3OK && y[0] == last && isfinite(y[1]) && isfinite(y[2]),
              "time, dte and an indicator");
        if (k == 250) {
            CHECK(GetFMUState(c, &s) == fmi3OK, "fmi3 state");
            CHECK(SerializedFMUStateSize(c, s, &n) == fmi3OK, "size");
            blob = malloc(n);
            CHECK(SerializeFMUState(c, s, blob, n) == fmi3OK, "serialize");
            CHECK(DeserializeFMUState(c, blob, n, &s2) == fmi3OK && SetFMUState(c, s2) == fmi3OK, "round trip");
            free(blob);
            FreeFMUState(c, &s2);
        }
    }
    CHECK(GetFloat64(c, read, 3, y, 2) == fmi3Error, "nValues that do not match");
    FreeFMUState(c, &s);
    FreeInstance(c);

    c = InstantiateModelExchange("me3", token, "", fmi3False, fmi3False, NULL, logger3);
    CHECK(c != NULL, "fmi3 Model Exchange");
    if (!c) return;
    CHECK(SetFloat64(c, vr, 5, v, 5) == fmi3OK, "start values");
    CHECK(EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) == fmi3OK, "initialization");
    CHECK(ExitInitializationMode(c) == fmi3OK, "exit initialization");
    CHECK(UpdateDiscreteStates(c, &b[0], &b[1], &b[2], &b[3], &event, &last) == fmi3OK, "update");
    CHECK(EnterContinuousTimeMode(c) == fmi3OK, "continuous time");
    CHECK(GetNumberOfContinuousStates(c, &nx) == fmi3OK && nx == NX, "number of states");
    CHECK(GetContinuousStates(c, x, NX) == fmi3OK, "states");
    t = 0.0;
    for (k = 0; k < 200; k++) {
        CHECK(GetContinuousStateDerivatives(c, dx, NX) == fmi3OK, "derivatives");
        for (i = 0; i < NX; i++) x[i] += 1e-6 * dx[i];
        t += 1e-6;
        CHECK(SetTime(c, t) == fmi3OK && SetContinuousStates(c, x, NX) == fmi3OK, "set point");
        CHECK(CompletedIntegratorStep(c, fmi3True, &event, &stop) == fmi3OK, "completed step");
    }
    CHECK(Terminate(c) == fmi3OK, "terminate");
    FreeInstance(c);
#undef LOAD3
}

int main(int argc, char **argv) {
    struct api f;
    void *lib;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c, c2, c3;
    fmi2Real t = 0.0, h = 1e-4, y[N_OUT], y2[N_OUT], geo[2];
    fmi2ValueReference geo_vr[] = {VR_S_B, VR_BASE_PITCH};
    long steps, k, windows_checked = 0;
    const char *cat_bad[] = {"logEverything"};
    fmi2FMUstate keep = NULL;

    if (argc < 3) {
        fprintf(stderr, "usage: %s <SpurGearMesh.so> <guid> [steps]\n", argv[0]);
        return 2;
    }
    steps = argc > 3 ? atol(argv[3]) : 5000;
    verbose = getenv("MEMCHECK_VERBOSE") != NULL;
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "fmi_memcheck: %s\n", dlerror());
        return 2;
    }
#define LOAD(name) f.name = (fmi2##name##TYPE *)sym(lib, "fmi2" #name)
    LOAD(GetVersion); LOAD(GetTypesPlatform); LOAD(Instantiate); LOAD(FreeInstance);
    LOAD(SetDebugLogging); LOAD(SetupExperiment); LOAD(EnterInitializationMode);
    LOAD(ExitInitializationMode); LOAD(Terminate); LOAD(Reset); LOAD(GetReal); LOAD(SetReal);
    LOAD(GetInteger); LOAD(GetFMUstate); LOAD(SetFMUstate); LOAD(FreeFMUstate);
    LOAD(SerializedFMUstateSize); LOAD(SerializeFMUstate); LOAD(DeSerializeFMUstate);
    LOAD(DoStep); LOAD(GetRealStatus); LOAD(GetStatus); LOAD(CancelStep);
    LOAD(EnterEventMode); LOAD(NewDiscreteStates); LOAD(EnterContinuousTimeMode);
    LOAD(CompletedIntegratorStep); LOAD(SetTime); LOAD(SetContinuousStates); LOAD(GetDerivatives);
    LOAD(GetEventIndicators); LOAD(GetContinuousStates); LOAD(GetNominalsOfContinuousStates);
    LOAD(GetDirectionalDerivative);

    CHECK(strcmp(f.GetVersion(), "2.0") == 0, "version");
    CHECK(strcmp(f.GetTypesPlatform(), "default") == 0, "types platform");

    /* Failed instantiations. */
    CHECK(f.Instantiate("x", fmi2CoSimulation, "{wrong}", "", &cb, fmi2False, fmi2False) == NULL, "wrong GUID");
    CHECK(f.Instantiate("x", (fmi2Type)7, argv[2], "", &cb, fmi2False, fmi2False) == NULL, "bad fmuType");
    CHECK(f.Instantiate(NULL, fmi2CoSimulation, argv[2], "", &cb, fmi2False, fmi2False) == NULL, "no name");

    c = f.Instantiate("a", fmi2CoSimulation, argv[2], "file:///tmp", &cb, fmi2False, fmi2True);
    c2 = f.Instantiate("b", fmi2CoSimulation, argv[2], NULL, &cb, fmi2False, fmi2False);
    CHECK(c && c2, "instantiate");
    if (!c || !c2) return 1;
    CHECK(f.SetDebugLogging(c, fmi2True, 0, NULL) == fmi2OK, "debug logging on");
    CHECK(f.SetDebugLogging(c2, fmi2True, 1, cat_bad) == fmi2Error, "unknown category");
    CHECK(f.Reset(c2) == fmi2OK, "reset after the error");

    init_paper_scene(&f, c);
    init_paper_scene(&f, c2);
    CHECK(f.GetReal(c, geo_vr, 2, geo) == fmi2OK, "s_b, base_pitch");

    for (k = 0; k < steps; k++) {
        unsigned i;
        CHECK(f.DoStep(c, t, h, fmi2True) == fmi2OK, "step %ld at t = %g", k, t);
        t += h;
        CHECK(f.GetReal(c, outputs, N_OUT, y) == fmi2OK, "outputs");
        for (i = 0; i < N_OUT; i++) CHECK(isfinite(y[i]), "output %u is %g", outputs[i], y[i]);
        for (i = 3; i < 7; i++) {
            CHECK(y[i] >= geo[0] - 2 * geo[1] - 1e-9 && y[i] <= geo[0] + 1e-9,
                  "contact coordinate %u = %.17g outside [s_b - 2 p_b, s_b] at t = %g", outputs[i], y[i], t);
            windows_checked++;
        }

        if (k % 500 == 250) {
            fmi2FMUstate s = NULL, s2 = NULL, bogus = (fmi2FMUstate)(size_t)0x1234;
            size_t n = 0;
            char *blob;
            fmi2Real t2 = 0.0;
            int j;
            CHECK(f.GetFMUstate(c, &s) == fmi2OK && s, "get state");
            CHECK(f.GetFMUstate(c, &s) == fmi2OK, "get state in place");
            blob = serialize(&f, c, s, &n);
            /* The other instance takes the state over and continues bit-identically. */
            CHECK(f.DeSerializeFMUstate(c2, blob, n, &s2) == fmi2OK && s2, "deserialize");
            CHECK(f.SetFMUstate(c2, s2) == fmi2OK, "set the deserialized state");
            CHECK(f.GetRealStatus(c2, fmi2LastSuccessfulTime, &t2) == fmi2OK && t2 == t, "time of the copy");
            for (j = 0; j < 3; j++) {
                fmi2Real ta = t, tb = t;
                CHECK(f.DoStep(c, ta, h, fmi2False) == fmi2OK, "step a");
                CHECK(f.DoStep(c2, tb, h, fmi2False) == fmi2OK, "step b");
                t += h;
                f.GetReal(c, outputs, N_OUT, y);
                f.GetReal(c2, outputs, N_OUT, y2);
                CHECK(memcmp(y, y2, sizeof y) == 0, "the copy differs after %d steps", j + 1);
            }
            /* Rewind a to the saved state (the master's loop time follows). */
            CHECK(f.SetFMUstate(c, s) == fmi2OK, "rewind");
            t -= 3 * h;
            CHECK(f.GetRealStatus(c, fmi2LastSuccessfulTime, &t2) == fmi2OK, "time after rewind");
            t = t2;
            /* Error paths on b, then recovery from its saved state. */
            CHECK(f.SetFMUstate(c2, bogus) == fmi2Error, "bogus state pointer");
            CHECK(f.SetFMUstate(c2, s) == fmi2Error, "state of another instance");
            CHECK(f.DeSerializeFMUstate(c2, blob, n / 2, &s2) == fmi2Error, "truncated blob");
            blob[n - 20] ^= 0x40;
            CHECK(f.DeSerializeFMUstate(c2, blob, n, &s2) == fmi2Error, "corrupted blob");
            CHECK(f.DoStep(c2, -1.0, h, fmi2False) == fmi2Error, "a step in the error state");
            CHECK(f.SetFMUstate(c2, s2) == fmi2OK, "recover b");
            CHECK(f.DoStep(c2, t + 1.0, h, fmi2False) == fmi2Error, "wrong time");
            CHECK(f.SetFMUstate(c2, s2) == fmi2OK, "recover b again");
            CHECK(f.CancelStep(c2) == fmi2Error, "no step to cancel");
            CHECK(f.Reset(c2) == fmi2OK, "reset b");
            init_paper_scene(&f, c2);
            CHECK(f.FreeFMUstate(c2, &s2) == fmi2OK && s2 == NULL, "free b's state");
            CHECK(f.FreeFMUstate(c2, &s2) == fmi2OK, "free NULL");
            s2 = s;
            CHECK(f.FreeFMUstate(c2, &s2) == fmi2Error, "free another instance's state");
            CHECK(f.FreeFMUstate(c, &s) == fmi2OK, "free a's state");
            s2 = blob; /* a readable heap pointer that is no FMU state */
            CHECK(f.SetFMUstate(c2, s2) == fmi2Error, "a heap pointer that is no state");
            free(blob);
            {
                fmi2ValueReference bad = 99999;
                fmi2Real x;
                CHECK(f.GetReal(c2, &bad, 1, &x) == fmi2Error, "unknown value reference");
                CHECK(f.Reset(c2) == fmi2OK, "reset b");
                init_paper_scene(&f, c2);
            }
        }
    }

    /* An FMU state left allocated: fmi2FreeInstance frees it. */
    CHECK(f.GetFMUstate(c2, &keep) == fmi2OK, "a state to leave behind");
    {
        fmi2Status st;
        CHECK(f.GetStatus(c, fmi2DoStepStatus, &st) == fmi2Discard, "no asynchronous step");
    }
    CHECK(f.Reset(c) == fmi2OK, "reset a");
    init_paper_scene(&f, c);
    t = 0.0;
    for (k = 0; k < 100; k++, t += h) CHECK(f.DoStep(c, t, h, fmi2True) == fmi2OK, "step after reset");
    CHECK(f.Terminate(c) == fmi2OK, "terminate");
    CHECK(f.DoStep(c, t, h, fmi2True) == fmi2Error, "a step after terminate");
    CHECK(f.GetReal(c, outputs, N_OUT, y) == fmi2OK, "outputs after terminate");
    f.FreeInstance(c);
    f.FreeInstance(c2);

    /* Many short-lived instances. */
    for (k = 0; k < 200; k++) {
        c3 = f.Instantiate("c", fmi2CoSimulation, argv[2], "", &cb, fmi2False, fmi2False);
        CHECK(c3 != NULL, "instantiate %ld", k);
        if (k % 2) init_paper_scene(&f, c3);
        f.FreeInstance(c3);
    }
    f.FreeInstance(NULL);

    internal_pair(lib, &f, &cb, argv[2], steps / 4);
    model_exchange(&f, &cb, argv[2]);
    fmi3(lib, argv[2]);

    dlclose(lib);
    printf("fmi_memcheck: %ld steps, %ld window checks, %ld log messages (%ld errors/discards), %d failures\n",
           steps, windows_checked, messages, error_messages, failures);
    return failures ? 1 : 0;
}
