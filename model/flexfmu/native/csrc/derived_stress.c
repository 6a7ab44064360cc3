/*
 * derived_stress.c - the derived outputs of a native LTI model (derived_stress.h): flexfmu/core/stress.py's formulas
 * with the same operations in the same order (numpy's x ** 2 is x * x; a sum of three is ((a + b) + c)).
 */
#include <math.h>
#include <stddef.h>

#include "derived_stress.h"

int ffx_derived_n_sources(int kind) {
    switch (kind) {
    case FFX_DERIVED_TENSOR_VON_MISES: return 6;
    case FFX_DERIVED_SECTION_SIGMA_MAX:
    case FFX_DERIVED_SECTION_VON_MISES: return 4;
    default: return 0;
    }
}

double ffx_von_mises(const double *s) {
    double sxx = s[0], syy = s[1], szz = s[2], sxy = s[3], syz = s[4], sxz = s[5];
    double a = sxx - syy, b = syy - szz, c = szz - sxx;
    return sqrt(0.5 * (a * a + b * b + c * c) + 3.0 * (sxy * sxy + syz * syz + sxz * sxz));
}

double ffx_section_sigma_max(int shape, const double *fibres, double N, double My, double Mz) {
    const double *f = fibres;
    if (shape == FFX_SECTION_RECTANGLE)
        return fabs(N) / f[FFX_FIBRE_A] + fabs(My) * f[FFX_FIBRE_Z_MAX] / f[FFX_FIBRE_IY]
               + fabs(Mz) * f[FFX_FIBRE_Y_MAX] / f[FFX_FIBRE_IZ];
    return fabs(N) / f[FFX_FIBRE_A] + hypot(My, Mz) * f[FFX_FIBRE_Z_MAX] / f[FFX_FIBRE_IY];
}

double ffx_section_von_mises(int shape, const double *fibres, double N, double T, double My, double Mz) {
    double sigma = ffx_section_sigma_max(shape, fibres, N, My, Mz);
    double tau = fabs(T) * fibres[FFX_FIBRE_ARM] / fibres[FFX_FIBRE_J];
    return sqrt(sigma * sigma + 3.0 * tau * tau);
}

void ffx_derived_evaluate(int n, const int32_t *kind, const int32_t *shape, const int32_t *output,
                          const int32_t *sources, const double *fibres, const unsigned char *want, double *y) {
    for (int k = 0; k < n; k++) {
        if (want && !want[output[k]]) continue;
        const int32_t *src = sources + (size_t)k * FFX_DERIVED_MAX_SOURCES;
        const double *f = fibres + (size_t)k * FFX_DERIVED_N_FIBRES;
        double v[FFX_DERIVED_MAX_SOURCES];
        int m = ffx_derived_n_sources(kind[k]);
        for (int i = 0; i < m; i++) v[i] = y[src[i]];
        if (kind[k] == FFX_DERIVED_TENSOR_VON_MISES)
            y[output[k]] = ffx_von_mises(v);
        else if (kind[k] == FFX_DERIVED_SECTION_SIGMA_MAX)
            y[output[k]] = ffx_section_sigma_max(shape[k], f, v[0], v[2], v[3]);
        else if (kind[k] == FFX_DERIVED_SECTION_VON_MISES)
            y[output[k]] = ffx_section_von_mises(shape[k], f, v[0], v[1], v[2], v[3]);
    }
}

/* sign(v): -1, 0, 1 (the zero subgradient of |v| at 0) */
static double sign(double v) { return v > 0.0 ? 1.0 : v < 0.0 ? -1.0 : 0.0; }

/* d sigma_max along (dN, dMy, dMz) */
static double sigma_max_derivative(int shape, const double *f, const double *v, const double *dv) {
    double d = sign(v[0]) * dv[0] / f[FFX_FIBRE_A];
    if (shape == FFX_SECTION_RECTANGLE)
        return d + sign(v[2]) * dv[2] * f[FFX_FIBRE_Z_MAX] / f[FFX_FIBRE_IY]
               + sign(v[3]) * dv[3] * f[FFX_FIBRE_Y_MAX] / f[FFX_FIBRE_IZ];
    double r = hypot(v[2], v[3]);
    return r > 0.0 ? d + (v[2] * dv[2] + v[3] * dv[3]) / r * f[FFX_FIBRE_Z_MAX] / f[FFX_FIBRE_IY] : d;
}

void ffx_derived_directional(int n, const int32_t *kind, const int32_t *shape, const int32_t *output,
                             const int32_t *sources, const double *fibres, const double *y, double *dy) {
    for (int k = 0; k < n; k++) {
        const int32_t *src = sources + (size_t)k * FFX_DERIVED_MAX_SOURCES;
        const double *f = fibres + (size_t)k * FFX_DERIVED_N_FIBRES;
        double v[FFX_DERIVED_MAX_SOURCES], dv[FFX_DERIVED_MAX_SOURCES], d = 0.0;
        int m = ffx_derived_n_sources(kind[k]);
        for (int i = 0; i < m; i++) v[i] = y[src[i]], dv[i] = dy[src[i]];
        if (kind[k] == FFX_DERIVED_TENSOR_VON_MISES) {
            /* vm^2 = 1/2 (a^2 + b^2 + c^2) + 3 (sxy^2 + syz^2 + sxz^2): vm dvm = 1/2 (a da + ...) + 3 (sxy dsxy + ...) */
            double vm = ffx_von_mises(v);
            double a = v[0] - v[1], b = v[1] - v[2], c = v[2] - v[0];
            double da = dv[0] - dv[1], db = dv[1] - dv[2], dc = dv[2] - dv[0];
            if (vm > 0.0)
                d = (0.5 * (a * da + b * db + c * dc) + 3.0 * (v[3] * dv[3] + v[4] * dv[4] + v[5] * dv[5])) / vm;
        } else if (kind[k] == FFX_DERIVED_SECTION_SIGMA_MAX) {
            d = sigma_max_derivative(shape[k], f, v, dv);
        } else if (kind[k] == FFX_DERIVED_SECTION_VON_MISES) {
            double sigma = ffx_section_sigma_max(shape[k], f, v[0], v[2], v[3]);
            double tau = fabs(v[1]) * f[FFX_FIBRE_ARM] / f[FFX_FIBRE_J];
            double vm = sqrt(sigma * sigma + 3.0 * tau * tau);
            double dtau = sign(v[1]) * dv[1] * f[FFX_FIBRE_ARM] / f[FFX_FIBRE_J];
            if (vm > 0.0) d = (sigma * sigma_max_derivative(shape[k], f, v, dv) + 3.0 * tau * dtau) / vm;
        }
        dy[output[k]] = d;
    }
}

int ffx_derived_check(int n, const int32_t *kind, const int32_t *shape, const int32_t *output, const int32_t *sources,
                      const double *fibres, int ny, const char **what, const char **allowed) {
    for (int k = 0; k < n; k++) {
        const int32_t *src = sources + (size_t)k * FFX_DERIVED_MAX_SOURCES;
        const double *f = fibres + (size_t)k * FFX_DERIVED_N_FIBRES;
        int m = ffx_derived_n_sources(kind[k]);
        int section = kind[k] != FFX_DERIVED_TENSOR_VON_MISES;
        *what = NULL;
        if (m == 0)
            *what = "an unknown kind", *allowed = "1 tensor_von_mises, 2 section_sigma_max, 3 section_von_mises";
        else if (section ? shape[k] < FFX_SECTION_CIRCLE || shape[k] > FFX_SECTION_RECTANGLE
                         : shape[k] != FFX_SECTION_NONE)
            *what = "a section shape that does not go with its kind",
            *allowed = "0 for tensor_von_mises; 1 circle, 2 tube or 3 rectangle for the section kinds";
        else if (output[k] < 0 || output[k] >= ny)
            *what = "an output index out of range", *allowed = "an output of the model";
        if (*what) return k;
        for (int j = 0; j < k; j++)
            if (output[j] == output[k]) {
                *what = "an output another entry computes too", *allowed = "one entry per derived output";
                return k;
            }
        for (int i = 0; i < FFX_DERIVED_MAX_SOURCES; i++) {
            int bad = i < m ? src[i] < 0 || src[i] >= ny : src[i] != -1;
            for (int j = 0; j < n && i < m && !bad; j++) bad = src[i] == output[j];
            if (bad) {
                *what = "a source index out of range, or a derived output as a source";
                *allowed = "the kind's number of sources, each an output of the linear part, then -1";
                return k;
            }
        }
        for (int i = 0; i < FFX_DERIVED_N_FIBRES; i++) {
            int positive = section && i <= FFX_FIBRE_J;
            if (!isfinite(f[i]) || (positive ? !(f[i] > 0.0) : !(f[i] >= 0.0))) {
                *what = "a section constant that is not a finite number of its range (NaN, inf, <= 0)";
                *allowed = "A, Iy, Iz, J finite > 0 and y_max, z_max, torsion_arm finite >= 0 (a tensor's: >= 0)";
                return k;
            }
        }
    }
    return -1;
}
