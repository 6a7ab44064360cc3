/*
 * native_front.c - the front (flexfmu_fmi2.c) in its native variant, as one translation unit of its own: a
 * native FMU's sources/ compile without any -D flag (CMakeLists.txt, or a tool that compiles the source files
 * listed in modelDescription.xml one by one).
 */
#define FLEXFMU_NATIVE 1
#include "flexfmu_fmi2.c"
