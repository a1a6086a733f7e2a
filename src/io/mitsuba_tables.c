/*
 * io/mitsuba_tables.c: the data tables of the Mitsuba loader.
 *
 * - Spectrum -> linear sRGB, as Mitsuba 3's RGB variants convert a list of wavelength:value pairs
 *   (its spectrum_list_to_srgb): the list times the CIE 1931 2-degree colour matching functions
 *   (the CIE's 5 nm values, CVRL ciexyz31, linearly interpolated), times the CIE D65 illuminant for
 *   reflectances and other non-emitter quantities, summed at 1000 wavelengths over 360..830 nm,
 *   normalized by Mitsuba's constants (1 / the integral of y-bar, and of y-bar D65), then XYZ ->
 *   linear sRGB with the ITU-R BT.709 / sRGB matrix; a flat reflectance of 1 is white. Emitters
 *   read spectra without D65, so a flat spectrum of 1 is the equal-energy illuminant E, slightly
 *   pink in sRGB. A single value is a constant (white for a reflectance).
 * - Named IORs: Mitsuba's table (include/mitsuba/render/ior.h).
 * - Conductors: RGB eta and k for the names of Mitsuba's measured conductor data: the values Mitsuba
 *   3.9's RGB variants compute from its spectral files (read back from its conductor plugin, so
 *   that named conductors render identically); Na, Ni and V, whose files Mitsuba 3 no longer ships,
 *   keep Tungsten's (Benedikt Bitterli's) integration of the same data. Mitsuba's "_palik" variants
 *   map to the base names. Small negative values, artefacts of the RGB fit, are clamped to 0.
 */
#include <string.h>
#include <strings.h>

#include "io/mitsuba_tables.h"

#define CIE_START 360
#define CIE_STEP 5
#define CIE_COUNT 95 /* 360..830 nm */

static const double cie_x[CIE_COUNT] = {
    0.0001299,    0.0002321,     0.0004149,    0.0007416,    0.001368,     0.002236,     0.004243,
    0.00765,      0.01431,       0.02319,      0.04351,      0.07763,      0.13438,      0.21477,
    0.2839,       0.3285,        0.34828,      0.34806,      0.3362,       0.3187,       0.2908,
    0.2511,       0.19536,       0.1421,       0.09564,      0.05795001,   0.03201,      0.0147,
    0.0049,       0.0024,        0.0093,       0.0291,       0.06327,      0.1096,       0.1655,
    0.2257499,    0.2904,        0.3597,       0.4334499,    0.5120501,    0.5945,       0.6784,
    0.7621,       0.8425,        0.9163,       0.9786,       1.0263,       1.0567,       1.0622,
    1.0456,       1.0026,        0.9384,       0.8544499,    0.7514,       0.6424,       0.5419,
    0.4479,       0.3608,        0.2835,       0.2187,       0.1649,       0.1212,       0.0874,
    0.0636,       0.04677,       0.0329,       0.0227,       0.01584,      0.01135916,   0.008110916,
    0.005790346,  0.004109457,   0.002899327,  0.00204919,   0.001439971,  0.0009999493, 0.0006900786,
    0.0004760213, 0.0003323011,  0.0002348261, 0.0001661505, 0.000117413,  0.00008307527, 0.00005870652,
    0.00004150994, 0.00002935326, 0.00002067383, 0.00001455977, 0.00001025398, 0.000007221456,
    0.000005085868, 0.000003581652, 0.000002522525, 0.000001776509, 0.000001251141};

static const double cie_y[CIE_COUNT] = {
    0.000003917,  0.000006965,  0.00001239,   0.00002202,   0.000039,     0.000064,     0.00012,
    0.000217,     0.000396,     0.00064,      0.00121,      0.00218,      0.004,        0.0073,
    0.0116,       0.01684,      0.023,        0.0298,       0.038,        0.048,        0.06,
    0.0739,       0.09098,      0.1126,       0.13902,      0.1693,       0.20802,      0.2586,
    0.323,        0.4073,       0.503,        0.6082,       0.71,         0.7932,       0.862,
    0.9148501,    0.954,        0.9803,       0.9949501,    1.0,          0.995,        0.9786,
    0.952,        0.9154,       0.87,         0.8163,       0.757,        0.6949,       0.631,
    0.5668,       0.503,        0.4412,       0.381,        0.321,        0.265,        0.217,
    0.175,        0.1382,       0.107,        0.0816,       0.061,        0.04458,      0.032,
    0.0232,       0.017,        0.01192,      0.00821,      0.005723,     0.004102,     0.002929,
    0.002091,     0.001484,     0.001047,     0.00074,      0.00052,      0.0003611,    0.0002492,
    0.0001719,    0.00012,      0.0000848,    0.00006,      0.0000424,    0.00003,      0.0000212,
    0.00001499,   0.0000106,    0.0000074657, 0.0000052578, 0.0000037029, 0.0000026078, 0.0000018366,
    0.0000012934, 0.00000091093, 0.00000064153, 0.00000045181};

static const double cie_z[CIE_COUNT] = {
    0.0006061,   0.001086,   0.001946,  0.003486,  0.006450001, 0.01054999,  0.02005001, 0.03621,
    0.06785001,  0.1102,     0.2074,    0.3713,    0.6456,      1.0390501,   1.3856,     1.62296,
    1.74706,     1.7826,     1.77211,   1.7441,    1.6692,      1.5281,      1.28764,    1.0419,
    0.8129501,   0.6162,     0.46518,   0.3533,    0.272,       0.2123,      0.1582,     0.1117,
    0.07824999,  0.05725001, 0.04216,   0.02984,   0.0203,      0.0134,      0.008749999, 0.005749999,
    0.0039,      0.002749999, 0.0021,   0.0018,    0.001650001, 0.0014,      0.0011,     0.001,
    0.0008,      0.0006,     0.00034,   0.00024,   0.00019,     0.0001,      0.00004999999, 0.00003,
    0.00002,     0.00001,    0,         0,         0,           0,           0,          0,
    0,           0,          0,         0,         0,           0,           0,          0,
    0,           0,          0,         0,         0,           0,           0,          0,
    0,           0,          0,         0,         0,           0,           0,          0,
    0,           0,          0,         0,         0,           0,           0};

/* CIE standard illuminant D65, relative spectral power (100 at 560 nm), 360..830 nm at 5 nm. */
static const double cie_d65[CIE_COUNT] = {46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204, 91.4860, 92.4589, 93.4318, 90.0570, 86.6823, 95.7736, 104.8650, 110.9360, 117.0080, 117.4100, 117.8120, 116.3360, 114.8610, 115.3920, 115.9230, 112.3670, 108.8110, 109.0820, 109.3540, 108.5780, 107.8020, 106.2960, 104.7900, 106.2390, 107.6890, 106.0470, 104.4050, 104.2250, 104.0460, 102.0230, 100.0000, 98.1671, 96.3342, 96.0611, 95.7880, 92.2368, 88.6856, 89.3459, 90.0062, 89.8026, 89.5991, 88.6489, 87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.8630, 80.0268, 80.1207, 80.2146, 81.2462, 82.2778, 80.2810, 78.2842, 74.0027, 69.7213, 70.6652, 71.6091, 72.9790, 74.3490, 67.9765, 61.6040, 65.7448, 69.8856, 72.4863, 75.0870, 69.3398, 63.5927, 55.0054, 46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.3040, 61.8779, 59.4519, 55.7054, 51.9590, 54.6998, 57.4406, 58.8765, 60.3125};

/* Mitsuba 3's normalizations of its CIE tables: 1 / integral of y-bar (MI_CIE_Y_NORMALIZATION)
 * and 1 / integral of y-bar D65 (MI_CIE_D65_NORMALIZATION), both over 360..830 nm. */
#define MTS_CIE_Y_NORMALIZATION 0.009367658735689113
#define MTS_CIE_D65_NORMALIZATION 0.010101273599490354
/* Mitsuba 3 integrates a wavelength list against the CIE curves at this many wavelengths evenly
 * spaced over 360..830 nm (its spectrum_list_to_srgb). */
#define MTS_SPECTRUM_STEPS 1000

/* XYZ -> linear sRGB (BT.709 primaries, D65), to the six digits Mitsuba 3's xyz_to_srgb uses. */
static const double xyz_to_rgb[3][3] = {{3.240479, -1.537150, -0.498535},
                                        {-0.969256, 1.875991, 0.041556},
                                        {0.055648, -0.204043, 1.057311}};

static double cmf(const double *tab, double lambda)
{
    double x = (lambda - CIE_START) / CIE_STEP;
    if (x < 0.0 || x > CIE_COUNT - 1)
        return 0.0;
    int i = (int)x;
    if (i >= CIE_COUNT - 1)
        return tab[CIE_COUNT - 1];
    double t = x - i;
    return (1.0 - t) * tab[i] + t * tab[i + 1];
}

static double spectrum_at(const double *wl, const double *val, int n, double lambda)
{
    if (n == 1)
        return val[0];
    if (lambda < wl[0] || lambda > wl[n - 1])
        return 0.0;
    int lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (wl[mid] <= lambda)
            lo = mid;
        else
            hi = mid;
    }
    double span = wl[hi] - wl[lo];
    if (!(span > 0.0))
        return val[lo];
    double t = (lambda - wl[lo]) / span;
    return (1.0 - t) * val[lo] + t * val[hi];
}

static void to_rgb(const double xyz[3], double rgb[3])
{
    for (int c = 0; c < 3; ++c)
        rgb[c] = xyz_to_rgb[c][0] * xyz[0] + xyz_to_rgb[c][1] * xyz[1] + xyz_to_rgb[c][2] * xyz[2];
}

/* A list of wavelength:value pairs in linear sRGB as Mitsuba 3's RGB variants read it
 * (spectrum_list_to_srgb): the list, linearly interpolated and zero outside its range, times the
 * CIE curves (times D65 for a reflectance-like quantity, d65) summed at MTS_SPECTRUM_STEPS
 * wavelengths, then XYZ -> sRGB; negative channels are clamped to 0. */
static spc_rgb spectrum_list_to_srgb(const double *wl, const double *val, int n, bool d65)
{
    double xyz[3] = {0, 0, 0};
    const double lo = CIE_START, hi = CIE_START + CIE_STEP * (CIE_COUNT - 1);
    for (int i = 0; i < MTS_SPECTRUM_STEPS; ++i) {
        double w = lo + (double)i / (MTS_SPECTRUM_STEPS - 1) * (hi - lo);
        if (w < wl[0] || w > wl[n - 1])
            continue;
        double v = spectrum_at(wl, val, n, w) * (d65 ? cmf(cie_d65, w) * MTS_CIE_D65_NORMALIZATION : 1.0);
        xyz[0] += cmf(cie_x, w) * v;
        xyz[1] += cmf(cie_y, w) * v;
        xyz[2] += cmf(cie_z, w) * v;
    }
    for (int c = 0; c < 3; ++c)
        xyz[c] *= (hi - lo) / MTS_SPECTRUM_STEPS * MTS_CIE_Y_NORMALIZATION;
    double rgb[3];
    to_rgb(xyz, rgb);
    for (int c = 0; c < 3; ++c)
        if (!(rgb[c] > 0.0))
            rgb[c] = 0.0;
    return spc_rgb3(rgb[0], rgb[1], rgb[2]);
}

spc_rgb mts_spectrum_to_rgb(const double *wavelengths, const double *values, int n)
{
    if (n >= 2)
        return spectrum_list_to_srgb(wavelengths, values, n, true);
    double xyz[3] = {0, 0, 0}, white[3] = {0, 0, 0};
    for (int lambda = CIE_START; lambda <= CIE_START + CIE_STEP * (CIE_COUNT - 1); ++lambda) {
        double s = spectrum_at(wavelengths, values, n, lambda);
        double x = cmf(cie_x, lambda), y = cmf(cie_y, lambda), z = cmf(cie_z, lambda);
        xyz[0] += s * x;
        xyz[1] += s * y;
        xyz[2] += s * z;
        white[0] += x;
        white[1] += y;
        white[2] += z;
    }
    double rgb[3], wrgb[3];
    to_rgb(xyz, rgb);
    to_rgb(white, wrgb);
    for (int c = 0; c < 3; ++c) {
        rgb[c] /= wrgb[c];
        if (!(rgb[c] > 0.0))
            rgb[c] = 0.0;
    }
    return spc_rgb3(rgb[0], rgb[1], rgb[2]);
}

/* The equal-energy spectrum E in linear sRGB as Mitsuba 3.9 computes it (1 nm CIE tables; printed
 * by its RGB variants for <spectrum value="1"/> on an emitter). Our 5 nm table gives the same to
 * 1e-4, which is visible on directly seen lights, so constant spectra use these. */
#define E_SRGB_R 1.20479
#define E_SRGB_G 0.948291
#define E_SRGB_B 0.908916

spc_rgb mts_spectrum_to_rgb_emission(const double *wavelengths, const double *values, int n)
{
    if (n == 1)
        return spc_rgb3(values[0] * E_SRGB_R, values[0] * E_SRGB_G, values[0] * E_SRGB_B);
    if (n >= 2)
        return spectrum_list_to_srgb(wavelengths, values, n, false);
    double xyz[3] = {0, 0, 0}, y_int = 0.0;
    for (int lambda = CIE_START; lambda <= CIE_START + CIE_STEP * (CIE_COUNT - 1); ++lambda) {
        double s = spectrum_at(wavelengths, values, n, lambda);
        double y = cmf(cie_y, lambda);
        xyz[0] += s * cmf(cie_x, lambda);
        xyz[1] += s * y;
        xyz[2] += s * cmf(cie_z, lambda);
        y_int += y;
    }
    double rgb[3];
    for (int c = 0; c < 3; ++c)
        xyz[c] /= y_int;
    to_rgb(xyz, rgb);
    for (int c = 0; c < 3; ++c)
        if (!(rgb[c] > 0.0))
            rgb[c] = 0.0;
    return spc_rgb3(rgb[0], rgb[1], rgb[2]);
}

double mts_srgb_to_linear(double v)
{
    if (v <= 0.04045)
        return v / 12.92;
    return pow((v + 0.055) / 1.055, 2.4);
}

typedef struct named_ior {
    const char *name;
    double ior;
} named_ior;

static const named_ior iors[] = {
    {"vacuum", 1.0},         {"helium", 1.000036},       {"hydrogen", 1.000132},
    {"air", 1.000277},       {"carbon dioxide", 1.00045}, {"water", 1.3330},
    {"acetone", 1.36},       {"ethanol", 1.361},         {"carbon tetrachloride", 1.461},
    {"glycerol", 1.4729},    {"benzene", 1.501},         {"silicone oil", 1.52045},
    {"bromine", 1.661},      {"water ice", 1.31},        {"fused quartz", 1.458},
    {"pyrex", 1.470},        {"acrylic glass", 1.49},    {"polypropylene", 1.49},
    {"bk7", 1.5046},         {"sodium chloride", 1.544}, {"amber", 1.55},
    {"pet", 1.5750},         {"diamond", 2.419}};

bool mts_named_ior(const char *name, double *ior)
{
    for (size_t i = 0; i < sizeof iors / sizeof iors[0]; ++i) {
        if (strcasecmp(iors[i].name, name) == 0) {
            *ior = iors[i].ior;
            return true;
        }
    }
    return false;
}

const char *mts_ior_names(void)
{
    return "vacuum, helium, hydrogen, air, carbon dioxide, water, acetone, ethanol, carbon tetrachloride, "
           "glycerol, benzene, silicone oil, bromine, water ice, fused quartz, pyrex, acrylic glass, "
           "polypropylene, bk7, sodium chloride, amber, pet, diamond";
}

typedef struct conductor {
    const char *name;
    double eta[3], k[3];
} conductor;

static const conductor conductors[] = {
    {"a-C", {2.9440458, 2.2271364, 1.9681617}, {0.8874649, 0.7992985, 0.8152900}},
    {"Ag", {0.1552762, 0.1167280, 0.1383876}, {4.8283544, 3.1222224, 2.1469011}},
    {"Al", {1.6575009, 0.8804047, 0.5212445}, {9.2238111, 6.2695022, 4.8370042}},
    {"AlAs", {3.6052959, 3.2329378, 2.2163186}, {0.0006794, 0.0, 0.0075127}},
    {"AlSb", {0.0, 4.1393747, 4.6692543}, {0.0, 0.0940091, 1.3005700}},
    {"Au", {0.1430360, 0.3753071, 1.4420453}, {3.9829969, 2.3855565, 1.6033592}},
    {"Be", {4.1850123, 3.1850293, 2.7840612}, {3.8354659, 3.0101223, 2.8689940}},
    {"Cr", {4.3696675, 2.9165053, 1.6549046}, {5.2065468, 4.2313061, 3.7546988}},
    {"CsI", {2.1448996, 1.7023189, 1.6624272}, {0.0, 0.0, 0.0}},
    {"Cu", {0.2010055, 0.9237495, 1.1022154}, {3.9132621, 2.4530451, 2.1420898}},
    {"Cu2O", {3.5517726, 2.9498696, 2.7518754}, {0.1142070, 0.1938969, 0.6061339}},
    {"CuO", {3.2475410, 2.4478052, 2.2102196}, {0.5210896, 0.5700307, 0.7221789}},
    {"d-C", {2.7087197, 2.3188257, 2.2288976}, {0.0, 0.0, 0.0}},
    {"Hg", {2.3989387, 1.4400280, 0.9095704}, {6.3275871, 4.3719249, 3.4217637}},
    {"HgTe", {4.7790399, 3.2311962, 2.6599011}, {1.6316127, 1.5808104, 1.7292874}},
    {"Ir", {3.0862999, 2.0821905, 1.6179146}, {5.5921531, 4.0670881, 3.2673120}},
    {"K", {0.0640432, 0.0464098, 0.0381849}, {2.1041996, 1.3489400, 0.9131259}},
    {"Li", {0.2657909, 0.1956183, 0.2209486}, {3.5401549, 2.3111234, 1.6686072}},
    {"MgO", {2.0895839, 1.6507235, 1.5948790}, {0.0, 0.0, 0.0}},
    {"Mo", {4.4839740, 3.5251307, 2.7763104}, {4.1114373, 3.4208269, 3.1506073}},
    {"Na", {0.0602665, 0.0561412, 0.0619909}, {3.1792906, 2.1124801, 1.5790940}},
    {"Nb", {3.4200740, 2.7900932, 2.3956294}, {3.4413946, 2.7376661, 2.5797458}},
    {"Ni", {2.3672754, 1.6633583, 1.4670554}, {4.4988330, 3.0501644, 2.3454274}},
    {"Rh", {2.5857935, 1.8602164, 1.5542634}, {6.7822604, 4.7029872, 3.9760730}},
    {"Se-e", {5.7228489, 4.1657362, 4.0813384}, {0.8711363, 1.1051575, 1.5653203}},
    {"Se", {4.0583115, 2.8429351, 2.8208535}, {0.7540495, 0.6384435, 0.5218076}},
    {"SiC", {3.1723416, 2.5259717, 2.4793706}, {7.538e-07, 0.0, 1.019e-05}},
    {"SnTe", {4.5242496, 1.9816450, 1.2815913}, {0.0, 0.0, 0.0}},
    {"Ta", {2.0627210, 2.3929389, 2.6279287}, {2.4083598, 1.7414864, 1.9470278}},
    {"Te-e", {7.5089068, 4.2964287, 2.3699877}, {5.5839286, 4.9472051, 3.9975922}},
    {"Te", {7.3902335, 4.4821048, 2.6371059}, {3.2560222, 3.5270588, 3.2920542}},
    {"ThF4", {1.8307136, 1.4422286, 1.3876476}, {0.0, 0.0, 0.0}},
    {"TiC", {3.7005284, 2.8374221, 2.5822871}, {3.2656350, 2.3515892, 2.1727905}},
    {"TiN", {1.6484497, 1.1505160, 1.3798234}, {3.3683281, 1.9434981, 1.1020677}},
    {"TiO2-e", {3.1065645, 2.5131683, 2.5824444}, {2.975e-05, 0.0, 0.0001827}},
    {"TiO2", {3.4566100, 2.8017359, 2.9051750}, {0.0001053, 0.0, 0.0006529}},
    {"VC", {3.6575661, 2.7527361, 2.5326719}, {3.0683007, 2.1986873, 1.9631927}},
    {"VN", {2.8656023, 2.1191890, 1.9400911}, {3.0322425, 2.0561156, 1.6163063}},
    {"V", {4.2775126, 3.5131538, 2.7611257}, {3.4911845, 2.8893581, 3.1116965}},
    {"W", {4.3708167, 3.3002465, 2.9984074}, {3.5006406, 2.6048739, 2.2732332}}};

bool mts_conductor_preset(const char *name, spc_rgb *eta, spc_rgb *k)
{
    char base[32];
    size_t n = strlen(name);
    const char *suffix = "_palik";
    size_t ls = strlen(suffix);
    if (n > ls && n - ls < sizeof base && strcmp(name + n - ls, suffix) == 0) {
        memcpy(base, name, n - ls);
        base[n - ls] = '\0';
        name = base;
    }
    for (size_t i = 0; i < sizeof conductors / sizeof conductors[0]; ++i) {
        if (strcmp(conductors[i].name, name) == 0) {
            *eta = spc_rgb3(conductors[i].eta[0], conductors[i].eta[1], conductors[i].eta[2]);
            *k = spc_rgb3(conductors[i].k[0], conductors[i].k[1], conductors[i].k[2]);
            return true;
        }
    }
    return false;
}

const char *mts_conductor_names(void)
{
    return "none, a-C, Ag, Al, AlAs, AlSb, Au, Be, Cr, CsI, Cu, Cu2O, CuO, d-C, Hg, HgTe, Ir, K, Li, MgO, Mo, "
           "Na, Nb, Ni, Rh, Se, Se-e, SiC, SnTe, Ta, Te, Te-e, ThF4, TiC, TiN, TiO2, TiO2-e, VC, VN, V, W "
           "(and the _palik variants)";
}
