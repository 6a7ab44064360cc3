"""flexfmu's C kernels (csrc/, C99, libc/libm only): the one compiled implementation of the per-step numerics,
called by the library through ctypes and compiled into native FMUs (flexfmu.fmi.native) with no Python."""
