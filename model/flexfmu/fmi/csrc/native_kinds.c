/*
 * native_kinds.c - the model kinds of a native FMU's library (native_kind.h): the LTI kind (clamped bodies), the
 * reframe kind (free bodies), the wec kind (the point absorber's wave, float, hydro and
 * PTO) and the moordyn kind (the Mooring's lines, by MoorDyn's library).  The Python runtime's library lists its one
 * kind in native_python.c instead.
 */
#include "native_kind.h"

extern const NativeKind native_lti_kind, native_reframe_kind, native_wec_kind, native_moordyn_kind;

const NativeKind *const native_kinds[]
    = {&native_lti_kind, &native_reframe_kind, &native_wec_kind, &native_moordyn_kind};
const size_t native_kind_count = sizeof native_kinds / sizeof *native_kinds;
