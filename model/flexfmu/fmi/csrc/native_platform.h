/*
 * native_platform.h - what the front (flexfmu_fmi2.c) takes from POSIX, for Windows (MSVC or MinGW) builds of
 * native FMUs: pthread mutexes on SRW locks and dladdr (the library's own file name) on GetModuleHandleEx and
 * GetModuleFileName.  Included only when _WIN32 is defined; Linux and macOS use pthreads and dlfcn.h.
 */
#ifndef FLEXFMU_NATIVE_PLATFORM_H
#define FLEXFMU_NATIVE_PLATFORM_H

#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#include <windows.h>

typedef SRWLOCK pthread_mutex_t;
#define PTHREAD_MUTEX_INITIALIZER SRWLOCK_INIT

static int pthread_mutex_init(pthread_mutex_t *m, const void *attributes) {
    (void)attributes;
    InitializeSRWLock(m);
    return 0;
}
static int pthread_mutex_lock(pthread_mutex_t *m) {
    AcquireSRWLockExclusive(m);
    return 0;
}
static int pthread_mutex_unlock(pthread_mutex_t *m) {
    ReleaseSRWLockExclusive(m);
    return 0;
}
static int pthread_mutex_destroy(pthread_mutex_t *m) {
    (void)m;
    return 0;
}

#if defined(_MSC_VER)
#define NATIVE_THREAD_LOCAL __declspec(thread)
#else
#define NATIVE_THREAD_LOCAL __thread
#endif

typedef struct {
    const char *dli_fname;
} Dl_info;

/* The file of the module that holds `address`, with '/' separators (the front walks up with strrchr('/')). */
static int dladdr(const void *address, Dl_info *info) {
    static NATIVE_THREAD_LOCAL char path[4096];
    HMODULE module = NULL;
    if (!GetModuleHandleExA(GET_MODULE_HANDLE_EX_FLAG_FROM_ADDRESS | GET_MODULE_HANDLE_EX_FLAG_UNCHANGED_REFCOUNT,
                            (LPCSTR)address, &module))
        return 0;
    DWORD n = GetModuleFileNameA(module, path, (DWORD)sizeof path);
    if (n == 0 || n >= sizeof path) return 0;
    for (DWORD i = 0; i < n; i++)
        if (path[i] == '\\') path[i] = '/';
    info->dli_fname = path;
    return 1;
}

#endif
