/* SpurGearTrain through its C API as a C master runs it, for the valgrind (memcheck) run of
 * tools/reliability.sh:
 *
 *   train_memcheck <SpurGearTrain.so> <guid> <steps> <vr dte1> <vr tau4> <vr n_bodies>
 *                  [<planetary set> <vr of its dte>]
 *
 * Loads the library with dlopen and runs: an instance that steps the default train `steps`
 * communication steps of 1e-4 s with outputs read and checked (finite) after every step, a load
 * torque changed on the way, FMU states every 500 steps (get, serialize, deserialize into a
 * second instance, set, continue both bit-identically, free); an instance refused at
 * initialization (a body joined to nothing), reset and run; error paths (unknown value
 * reference, a step before initialization, a NaN input); and frees everything. Exits 0 if every
 * check passed. The value references come from the packaged modelDescription.xml. With a
 * planetary set (a file of lines `R|I|B <vr> <value>`: its start values), a third instance runs
 * it for `steps` steps, its loops and carrier included, and then a copy with one planet moved
 * off the assembly condition is refused.
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
            fprintf(stderr, "train_memcheck: line %d: ", __LINE__);        \
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
    (void)instance;
    (void)category;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message, ap);
    va_end(ap);
    if (getenv("TRAIN_MEMCHECK_VERBOSE") || status >= fmi2Warning) {
        if (getenv("TRAIN_MEMCHECK_VERBOSE")) fprintf(stderr, "[%d] %s\n", (int)status, text);
    }
}

#define F(name) fmi2##name##TYPE *name = (fmi2##name##TYPE *)dlsym(lib, "fmi2" #name)

/* Sets the start values of a file of lines `R|I|B <vr> <value>`; returns how many failed. With
 * `skew_vr`, that Real is set to `skew` instead. */
static int set_all(void *lib, fmi2Component c, const char *path, fmi2ValueReference skew_vr,
                   double skew) {
    F(SetReal); F(SetInteger); F(SetBoolean);
    FILE *f = fopen(path, "r");
    if (!f) return 1;
    char kind;
    unsigned long vr;
    double x;
    int bad = 0;
    while (fscanf(f, " %c %lu %lf", &kind, &vr, &x) == 3) {
        fmi2ValueReference r = (fmi2ValueReference)vr;
        if (kind == 'R') {
            fmi2Real v = (r == skew_vr) ? skew : x;
            bad += SetReal(c, &r, 1, &v) != fmi2OK;
        } else if (kind == 'I') {
            fmi2Integer v = (fmi2Integer)x;
            bad += SetInteger(c, &r, 1, &v) != fmi2OK;
        } else {
            fmi2Boolean v = x != 0.0;
            bad += SetBoolean(c, &r, 1, &v) != fmi2OK;
        }
    }
    fclose(f);
    return bad;
}

int main(int argc, char **argv) {
    if (argc < 7) {
        fprintf(stderr, "usage: train_memcheck <so> <guid> <steps> <vr dte1> <vr tau4> <vr n_bodies>\n");
        return 2;
    }
    const char *guid = argv[2];
    long steps = atol(argv[3]);
    fmi2ValueReference vr_dte = (fmi2ValueReference)atol(argv[4]);
    fmi2ValueReference vr_tau4 = (fmi2ValueReference)atol(argv[5]);
    fmi2ValueReference vr_nb = (fmi2ValueReference)atol(argv[6]);
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 2;
    }
    F(Instantiate); F(FreeInstance); F(SetupExperiment); F(EnterInitializationMode);
    F(ExitInitializationMode); F(DoStep); F(GetReal); F(SetReal); F(SetInteger); F(Reset);
    F(GetFMUstate); F(SetFMUstate); F(FreeFMUstate); F(SerializedFMUstateSize);
    F(SerializeFMUstate); F(DeSerializeFMUstate); F(Terminate);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};

    fmi2Component a = Instantiate("a", fmi2CoSimulation, guid, "", &cb, fmi2False, fmi2True);
    fmi2Component b = Instantiate("b", fmi2CoSimulation, guid, "", &cb, fmi2False, fmi2False);
    CHECK(a && b, "instantiate");
    const double h = 1e-4, stop = (double)steps * h;
    fmi2Component both[2] = {a, b};
    for (int i = 0; i < 2; i++) {
        CHECK(SetupExperiment(both[i], fmi2False, 0.0, 0.0, fmi2True, stop) == fmi2OK, "setup");
        CHECK(EnterInitializationMode(both[i]) == fmi2OK, "enter");
        CHECK(ExitInitializationMode(both[i]) == fmi2OK, "exit");
    }
    /* Error paths on a third instance: unknown value reference, NaN input. */
    fmi2Component c = Instantiate("c", fmi2CoSimulation, guid, "", &cb, fmi2False, fmi2True);
    double x = 0.0;
    fmi2ValueReference bogus = 99999999;
    CHECK(GetReal(c, &bogus, 1, &x) == fmi2Error, "unknown value reference");
    FreeInstance(c);
    c = Instantiate("c", fmi2CoSimulation, guid, "", &cb, fmi2False, fmi2True);
    double nan = NAN;
    CHECK(SetReal(c, &vr_tau4, 1, &nan) == fmi2Error, "NaN input");
    FreeInstance(c);
    /* A body joined to nothing: refused at initialization; after a reset the default runs. */
    c = Instantiate("c", fmi2CoSimulation, guid, "", &cb, fmi2False, fmi2True);
    fmi2Integer five = 5;
    CHECK(SetInteger(c, &vr_nb, 1, &five) == fmi2OK, "n_bodies");
    CHECK(SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup c");
    CHECK(EnterInitializationMode(c) == fmi2OK, "enter c");
    CHECK(ExitInitializationMode(c) == fmi2Error, "a disconnected body is refused");
    CHECK(Reset(c) == fmi2OK, "reset");
    CHECK(SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup c again");
    CHECK(EnterInitializationMode(c) == fmi2OK && ExitInitializationMode(c) == fmi2OK, "init c");
    CHECK(DoStep(c, 0.0, h, fmi2True) == fmi2OK, "a step of c");
    Terminate(c);
    FreeInstance(c);

    if (argc >= 9) {
        /* A planetary set: the scene's start values, run, then refused off its assembly
         * condition (the last planet's orbit angle, argv[9], moved by a third of a tooth). */
        fmi2ValueReference vr_p = (fmi2ValueReference)atol(argv[8]);
        fmi2Component p = Instantiate("p", fmi2CoSimulation, guid, "", &cb, fmi2False, fmi2True);
        CHECK(p != NULL, "instantiate p");
        CHECK(set_all(lib, p, argv[7], 0, 0.0) == 0, "planetary start values");
        CHECK(SetupExperiment(p, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup p");
        CHECK(EnterInitializationMode(p) == fmi2OK && ExitInitializationMode(p) == fmi2OK, "init p");
        for (long k = 0; k < steps; k++) {
            CHECK(DoStep(p, (double)k * h, h, fmi2True) == fmi2OK, "step p at %g", (double)k * h);
            double d = NAN;
            GetReal(p, &vr_p, 1, &d);
            CHECK(isfinite(d), "planetary dte at step %ld", k);
            if (failures > 20) break;
        }
        Terminate(p);
        FreeInstance(p);
        if (argc >= 11) {
            fmi2ValueReference vr_orbit = (fmi2ValueReference)atol(argv[9]);
            p = Instantiate("p", fmi2CoSimulation, guid, "", &cb, fmi2False, fmi2True);
            CHECK(set_all(lib, p, argv[7], vr_orbit, atof(argv[10])) == 0, "skewed start values");
            CHECK(SetupExperiment(p, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK, "setup p'");
            CHECK(EnterInitializationMode(p) == fmi2OK, "enter p'");
            CHECK(ExitInitializationMode(p) == fmi2Error, "a planet off the assembly condition is refused");
            FreeInstance(p);
        }
    }

    double t = 0.0;
    for (long k = 0; k < steps; k++, t = (double)k * h) {
        if (k == steps / 2) {
            double brake = -50.0;
            CHECK(SetReal(a, &vr_tau4, 1, &brake) == fmi2OK, "brake a");
            CHECK(SetReal(b, &vr_tau4, 1, &brake) == fmi2OK, "brake b");
        }
        CHECK(DoStep(a, t, h, fmi2True) == fmi2OK, "step a at %g", t);
        CHECK(DoStep(b, t, h, fmi2True) == fmi2OK, "step b at %g", t);
        double da = NAN, db = NAN;
        GetReal(a, &vr_dte, 1, &da);
        GetReal(b, &vr_dte, 1, &db);
        CHECK(isfinite(da) && da == db, "dte at %g: %g vs %g", t, da, db);
        if (k % 500 == 250) {
            fmi2FMUstate s = NULL, s2 = NULL;
            size_t size = 0;
            CHECK(GetFMUstate(a, &s) == fmi2OK, "get state");
            CHECK(SerializedFMUstateSize(a, s, &size) == fmi2OK && size > 0, "size");
            char *bytes = malloc(size);
            CHECK(SerializeFMUstate(a, s, bytes, size) == fmi2OK, "serialize");
            CHECK(DeSerializeFMUstate(b, bytes, size, &s2) == fmi2OK, "deserialize");
            CHECK(SetFMUstate(b, s2) == fmi2OK, "set state");
            free(bytes);
            FreeFMUstate(a, &s);
            FreeFMUstate(b, &s2);
        }
        if (failures > 20) break;
    }
    Terminate(a);
    Terminate(b);
    FreeInstance(a);
    FreeInstance(b);
    dlclose(lib);
    if (failures) {
        fprintf(stderr, "train_memcheck: %d checks failed\n", failures);
        return 1;
    }
    printf("train_memcheck: %ld steps of two instances, FMU states, error paths: all checks passed\n", steps);
    return 0;
}
