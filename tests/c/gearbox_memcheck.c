/* A gearbox FMU (package-train --gearbox) through its C API, for the valgrind run of
 * tools/reliability.sh:
 *
 *   gearbox_memcheck <NAME.so> <guid> <steps> <resource URI> <missing URI> <damaged URI>
 *                    <vr of a Real output> <vr of a gear's E>
 *
 * Instantiates from the resource URI (the unzipped FMU's resources/gearbox.toml), sets a gear's
 * key, runs `steps` Co-Simulation steps of 1e-4 s reading an output (finite) after each, saves,
 * serializes, deserializes into a second instance and continues both bit-identically, resets
 * and runs again; checks that a missing and a damaged gearbox file fail fmi2Instantiate (NULL)
 * and that a Model Exchange instance reads exactly its states; frees everything. Exits 0 if
 * every check passed.
 */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"

static int failures = 0;

#define CHECK(cond, ...)                                                   \
    do {                                                                   \
        if (!(cond)) {                                                     \
            fprintf(stderr, "gearbox_memcheck: line %d: ", __LINE__);      \
            fprintf(stderr, __VA_ARGS__);                                  \
            fprintf(stderr, "\n");                                         \
            failures++;                                                    \
        }                                                                  \
    } while (0)

static int errors_logged = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    char text[4096];
    va_list ap;
    (void)env;
    (void)instance;
    (void)category;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message, ap);
    va_end(ap);
    if (status >= fmi2Error) errors_logged++;
    if (getenv("GEARBOX_MEMCHECK_VERBOSE")) fprintf(stderr, "[%d] %s\n", (int)status, text);
}

#define F(name) fmi2##name##TYPE *name = (fmi2##name##TYPE *)dlsym(lib, "fmi2" #name)

int main(int argc, char **argv) {
    if (argc < 9) {
        fprintf(stderr, "usage: gearbox_memcheck SO GUID STEPS URI MISSING DAMAGED VR_OUT VR_E\n");
        return 2;
    }
    const char *guid = argv[2];
    long steps = atol(argv[3]);
    const char *uri = argv[4];
    fmi2ValueReference vr_out = (fmi2ValueReference)atol(argv[7]);
    fmi2ValueReference vr_e = (fmi2ValueReference)atol(argv[8]);
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 2;
    }
    F(Instantiate); F(FreeInstance); F(SetupExperiment); F(EnterInitializationMode);
    F(ExitInitializationMode); F(DoStep); F(GetReal); F(SetReal); F(Reset); F(Terminate);
    F(GetFMUstate); F(SetFMUstate); F(FreeFMUstate); F(SerializedFMUstateSize);
    F(SerializeFMUstate); F(DeSerializeFMUstate); F(GetContinuousStates);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};

    /* A missing and a damaged gearbox file: refused at instantiation, with a message. */
    for (int k = 5; k <= 6; k++) {
        int before = errors_logged;
        fmi2Component bad = Instantiate("bad", fmi2CoSimulation, guid, argv[k], &cb, fmi2False,
                                        fmi2False);
        CHECK(bad == NULL, "instantiated from %s", argv[k]);
        CHECK(errors_logged > before, "no error logged for %s", argv[k]);
        if (bad) FreeInstance(bad);
    }

    fmi2Component a = Instantiate("a", fmi2CoSimulation, guid, uri, &cb, fmi2False, fmi2False);
    fmi2Component b = Instantiate("b", fmi2CoSimulation, guid, uri, &cb, fmi2False, fmi2False);
    CHECK(a && b, "instantiate from %s", uri);
    if (!a || !b) return 1;
    double e = 2.0e11, bad_e = -1.0;
    CHECK(SetReal(a, &vr_e, 1, &e) == fmi2OK, "a gear's E");
    CHECK(SetReal(a, &vr_e, 1, &bad_e) == fmi2Error, "a negative E is refused");
    CHECK(Reset(a) == fmi2OK && SetReal(a, &vr_e, 1, &e) == fmi2OK, "reset, E again");
    const double h = 1e-4;
    CHECK(SetupExperiment(a, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup");
    CHECK(EnterInitializationMode(a) == fmi2OK && ExitInitializationMode(a) == fmi2OK, "init");
    double y = 0.0, y2 = 0.0;
    for (long k = 0; k < steps; k++) {
        CHECK(DoStep(a, (double)k * h, h, fmi2True) == fmi2OK, "step %ld", k);
        CHECK(GetReal(a, &vr_out, 1, &y) == fmi2OK && isfinite(y), "output at step %ld", k);
        if (k == steps / 2) {
            fmi2FMUstate s = NULL, s2 = NULL;
            size_t n = 0;
            CHECK(GetFMUstate(a, &s) == fmi2OK && SerializedFMUstateSize(a, s, &n) == fmi2OK,
                  "save");
            char *bytes = malloc(n);
            CHECK(SerializeFMUstate(a, s, bytes, n) == fmi2OK, "serialize");
            CHECK(DeSerializeFMUstate(b, bytes, n, &s2) == fmi2OK, "deserialize");
            CHECK(SetFMUstate(b, s2) == fmi2OK, "set");
            free(bytes);
            FreeFMUstate(a, &s);
            FreeFMUstate(b, &s2);
        }
        if (k > steps / 2) {
            CHECK(DoStep(b, (double)k * h, h, fmi2True) == fmi2OK, "step b %ld", k);
            CHECK(GetReal(b, &vr_out, 1, &y2) == fmi2OK && y2 == y, "b at step %ld", k);
        }
    }
    Terminate(a);
    FreeInstance(a);
    FreeInstance(b);

    /* Model Exchange: the states are read with exactly the gearbox's count (the master's nx
     * comes from the modelDescription; a wrong one is refused). */
    fmi2Component m = Instantiate("m", fmi2ModelExchange, guid, uri, &cb, fmi2False, fmi2False);
    CHECK(m != NULL, "a Model Exchange instance");
    if (m) {
        CHECK(SetupExperiment(m, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup m");
        CHECK(EnterInitializationMode(m) == fmi2OK && ExitInitializationMode(m) == fmi2OK,
              "init m");
        double x[64];
        CHECK(GetContinuousStates(m, x, 34) == fmi2Error, "SpurGearTrain's 34 states refused");
        FreeInstance(m);
    }
    dlclose(lib);
    if (failures)
        fprintf(stderr, "gearbox_memcheck: %d checks failed\n", failures);
    else
        printf("gearbox_memcheck: %ld steps, FMU states, Model Exchange, missing and damaged "
               "files: all checks passed\n", steps);
    return failures ? 1 : 0;
}
