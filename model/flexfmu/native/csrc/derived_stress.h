/*
 * derived_stress.h - the outputs a native LTI model computes from its other outputs, not linearly: the von Mises
 * stress of six stress outputs and the largest axial and von Mises stresses of a beam section from its section
 * forces (N, T, My, Mz).  The formulas are flexfmu/core/stress.py's (von_mises, SectionFibres.sigma_max and
 * .von_mises: the one home of them in Python), evaluated here with the same operations in the same order, so with
 * the same inputs the two give the same bits (compiled without FMA contraction, -ffp-contract=off).
 *
 * A derived output k (of n): kind[k] (FFX_DERIVED_*), shape[k] (FFX_SECTION_*: FFX_SECTION_NONE for the tensor
 * kind), output[k] its index in y, sources[k * FFX_DERIVED_MAX_SOURCES + i] the indices in y of its sources (six
 * stresses in VOIGT order xx, yy, zz, xy, yz, xz; or N, T, My, Mz followed by -1, -1), fibres[k * FFX_DERIVED_N_FIBRES
 * + i] the section's A, Iy, Iz, J (m^2, m^4), y_max, z_max, torsion_arm (m) (zeros for the tensor kind).  The
 * sources are outputs of the linear part: no derived output is another's source.
 *
 * C99, libm only; nothing allocates.  Used by flexfmu/fmi/csrc/native_lti.c (the FMU) and through ctypes by
 * flexfmu.native.lti_kernel (LtiKernel's outputs).
 */
#ifndef FLEXFMU_DERIVED_STRESS_H
#define FLEXFMU_DERIVED_STRESS_H

#include <stdint.h>

/* the kinds (flexfmu.core.stress.DERIVED_KINDS, in that order from 1) */
enum { FFX_DERIVED_TENSOR_VON_MISES = 1, FFX_DERIVED_SECTION_SIGMA_MAX = 2, FFX_DERIVED_SECTION_VON_MISES = 3 };
/* a section's outline (flexfmu.core.stress.SECTION_SHAPES, in that order from 1): circle and tube (the outer fibre at
   radius y_max = z_max), rectangle (the corners) */
enum { FFX_SECTION_NONE = 0, FFX_SECTION_CIRCLE = 1, FFX_SECTION_TUBE = 2, FFX_SECTION_RECTANGLE = 3 };
#define FFX_DERIVED_MAX_SOURCES 6
#define FFX_DERIVED_N_FIBRES 7
enum { FFX_FIBRE_A, FFX_FIBRE_IY, FFX_FIBRE_IZ, FFX_FIBRE_J, FFX_FIBRE_Y_MAX, FFX_FIBRE_Z_MAX, FFX_FIBRE_ARM };

/* The number of sources of a kind (6 or 4), 0 for an unknown kind. */
int ffx_derived_n_sources(int kind);

/* sqrt(1/2 ((sxx - syy)^2 + (syy - szz)^2 + (szz - sxx)^2) + 3 (sxy^2 + syz^2 + sxz^2)) of s in VOIGT order. */
double ffx_von_mises(const double *s);

/* |N| / A + hypot(My, Mz) z_max / Iy (circle, tube), |N| / A + |My| z_max / Iy + |Mz| y_max / Iz (rectangle). */
double ffx_section_sigma_max(int shape, const double *fibres, double N, double My, double Mz);

/* sqrt(sigma^2 + 3 tau^2), sigma = ffx_section_sigma_max, tau = |T| torsion_arm / J. */
double ffx_section_von_mises(int shape, const double *fibres, double N, double T, double My, double Mz);

/* y[output[k]] of its sources' y for every k with (want == NULL or want[output[k]]). */
void ffx_derived_evaluate(int n, const int32_t *kind, const int32_t *shape, const int32_t *output,
                          const int32_t *sources, const double *fibres, const unsigned char *want, double *y);

/* The derivatives dy[output[k]] along a direction from the sources' values y and derivatives dy (chain rule; where a
   formula has a kink, |v| at v = 0, a norm at the origin, the zero subgradient: a central difference's value). */
void ffx_derived_directional(int n, const int32_t *kind, const int32_t *shape, const int32_t *output,
                             const int32_t *sources, const double *fibres, const double *y, double *dy);

/* Checks the n entries against ny outputs: -1 when all are valid, else the first bad entry k, with what is wrong
   with it and what is allowed in `what` and `allowed` (static texts). */
int ffx_derived_check(int n, const int32_t *kind, const int32_t *shape, const int32_t *output, const int32_t *sources,
                      const double *fibres, int ny, const char **what, const char **allowed);

#endif
