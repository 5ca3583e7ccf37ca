/*
 * What the C hosts here share (fmi2_host.c, native_host.c, me_host.c): loading an FMU binary
 * (dlopen on POSIX, LoadLibrary on Windows) and its FMI 2.0 functions. Included by each host
 * (static inline functions: no separate object to link, no warning for those a host does
 * not call); the host includes fmi2Functions.h first.
 */
#ifndef HOST_LOAD_H
#define HOST_LOAD_H

#include <stdio.h>
#include <stdlib.h>

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#endif

/* The loader's reason for the last failure ("" where it gives none). */
static inline const char *host_error(void)
{
#ifdef _WIN32
    return "";
#else
    const char *e = dlerror();
    return e ? e : "";
#endif
}

/* The binary at path, or NULL (host_error says why). */
static inline void *host_open(const char *path)
{
#ifdef _WIN32
    return (void *)LoadLibraryA(path);
#else
    return dlopen(path, RTLD_NOW | RTLD_LOCAL);
#endif
}

/* The function `name` of the binary; if it has none, "<who>: <name> not found in the FMU
 * binary" on stderr and the host leaves through leave(2). */
static inline void *host_symbol(void *lib, const char *name, const char *who, void (*leave)(int))
{
    void *f;
#ifdef _WIN32
    f = (void *)GetProcAddress((HMODULE)lib, name);
#else
    f = dlsym(lib, name);
#endif
    if (f == NULL) {
        fprintf(stderr, "%s: %s not found in the FMU binary: %s\n", who, name, host_error());
        leave(2);
    }
    return f;
}

/* The co-simulation functions a run through the state machine calls. */
typedef struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2DoStepTYPE *do_step;
    fmi2TerminateTYPE *terminate;
    fmi2FreeInstanceTYPE *free_instance;
} HostCs;

/* Load them (a function pointer from dlsym is assigned through a void * lvalue, as POSIX
 * allows); a missing one leaves as host_symbol does. */
static inline void host_load_cs(HostCs *cs, void *lib, const char *who, void (*leave)(int))
{
    *(void **)&cs->instantiate = host_symbol(lib, "fmi2Instantiate", who, leave);
    *(void **)&cs->setup = host_symbol(lib, "fmi2SetupExperiment", who, leave);
    *(void **)&cs->enter_init = host_symbol(lib, "fmi2EnterInitializationMode", who, leave);
    *(void **)&cs->exit_init = host_symbol(lib, "fmi2ExitInitializationMode", who, leave);
    *(void **)&cs->set_real = host_symbol(lib, "fmi2SetReal", who, leave);
    *(void **)&cs->get_real = host_symbol(lib, "fmi2GetReal", who, leave);
    *(void **)&cs->do_step = host_symbol(lib, "fmi2DoStep", who, leave);
    *(void **)&cs->terminate = host_symbol(lib, "fmi2Terminate", who, leave);
    *(void **)&cs->free_instance = host_symbol(lib, "fmi2FreeInstance", who, leave);
}

#endif
