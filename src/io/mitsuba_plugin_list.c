/*
 * io/mitsuba_plugin_list.c: every plugin of Mitsuba 3 (3.9) by category, whether specula's loader
 * reads it, the parameters it reads with their defaults, and what differs. docs/PLUGINS.md is this
 * table printed (mts_plugins_markdown; tests/test_plugins.c checks that the committed file equals
 * it, and that the loader accepts every plugin marked read and refuses every one marked not read,
 * with an error naming it).
 *
 * Parameters are written "name default" (a parameter Mitsuba has and specula does not read is
 * listed in the note); "-" for none. A bsdf, shape, emitter, texture, medium, phase, volume or
 * integrator row ends with the builder the loader calls for that type (mitsuba_builders.h): adding a
 * plugin of those categories is one row here and its builder. The other categories (sensor, film,
 * rfilter, sampler) are read by the walk (mitsuba_xml.c), which accepts a type by its row here.
 * The loader's "unknown type" errors list the names this table marks read.
 */
#include "io/mitsuba_plugin_list.h"

#include <stdio.h>
#include <string.h>

#include "io/mitsuba_builders.h"

static const mts_plugin plugins[] = {
    /* ---- BSDFs ---- */
    {"bsdf", "diffuse", MTS_PLUGIN_YES, "reflectance 0.5", "", mts_bsdf_diffuse},
    {"bsdf", "dielectric", MTS_PLUGIN_YES,
     "int_ior \"bk7\", ext_ior \"air\", specular_reflectance 1, specular_transmittance 1", "", mts_bsdf_dielectric},
    {"bsdf", "thindielectric", MTS_PLUGIN_YES,
     "int_ior \"bk7\", ext_ior \"air\", specular_reflectance 1, specular_transmittance 1",
     "its transmission is a null event for volpath, as in Mitsuba", mts_bsdf_thindielectric},
    {"bsdf", "roughdielectric", MTS_PLUGIN_YES,
     "distribution \"beckmann\", alpha 0.1 (alpha_u, alpha_v), int_ior \"bk7\", ext_ior \"air\", sample_visible true, "
     "specular_reflectance 1, specular_transmittance 1",
     "", mts_bsdf_roughdielectric},
    {"bsdf", "conductor", MTS_PLUGIN_YES, "material \"none\" (or eta, k), specular_reflectance 1",
     "spectral eta/k are converted to RGB (see bench/RESULTS.md for the colour difference)", mts_bsdf_conductor},
    {"bsdf", "roughconductor", MTS_PLUGIN_YES,
     "material \"none\" (or eta, k), distribution \"beckmann\", alpha 0.1 (alpha_u, alpha_v), sample_visible true, "
     "specular_reflectance 1",
     "", mts_bsdf_roughconductor},
    {"bsdf", "plastic", MTS_PLUGIN_YES,
     "diffuse_reflectance 0.5, specular_reflectance 1, int_ior \"polypropylene\", ext_ior \"air\", nonlinear false", "",
     mts_bsdf_plastic},
    {"bsdf", "roughplastic", MTS_PLUGIN_YES,
     "diffuse_reflectance 0.5, specular_reflectance 1, distribution \"beckmann\", alpha 0.1, int_ior "
     "\"polypropylene\", ext_ior \"air\", nonlinear false, sample_visible true",
     "", mts_bsdf_roughplastic},
    {"bsdf", "twosided", MTS_PLUGIN_YES, "one or two nested bsdfs", "", mts_bsdf_twosided},
    {"bsdf", "bumpmap", MTS_PLUGIN_YES, "a nested texture (height), scale 1, a nested bsdf", "", mts_bsdf_bumpmap},
    {"bsdf", "normalmap", MTS_PLUGIN_YES, "normalmap (a bitmap texture), a nested bsdf", "", mts_bsdf_normalmap},
    {"bsdf", "blendbsdf", MTS_PLUGIN_YES, "weight 0.5 (float or texture), two nested bsdfs", "", mts_bsdf_blendbsdf},
    {"bsdf", "mask", MTS_PLUGIN_YES, "opacity 0.5 (float or texture), a nested bsdf",
     "its hole is a null event for volpath", mts_bsdf_mask},
    {"bsdf", "null", MTS_PLUGIN_YES, "-", "", mts_bsdf_null},
    {"bsdf", "principled", MTS_PLUGIN_YES,
     "base_color 0.5, roughness 0.5, anisotropic 0, metallic 0, spec_trans 0, eta or specular 0.5, spec_tint 0, "
     "sheen 0, sheen_tint 0, flatness 0, clearcoat 0, clearcoat_gloss 0 (each a float or texture), "
     "main_specular_sampling_rate 1, clearcoat_sampling_rate 1, diffuse_reflectance_sampling_rate 1",
     "", mts_bsdf_principled},
    {"bsdf", "principledthin", MTS_PLUGIN_YES,
     "base_color 0.5, roughness 0.5, anisotropic 0, spec_trans 0, eta 1.5, spec_tint 0, sheen 0, sheen_tint 0, "
     "flatness 0, diff_trans 0 (each a float or texture), specular_reflectance_sampling_rate 1, "
     "specular_transmittance_sampling_rate 1, diffuse_reflectance_sampling_rate 1, "
     "diffuse_transmittance_sampling_rate 1",
     "", mts_bsdf_principledthin},
    {"bsdf", "pplastic", MTS_PLUGIN_YES,
     "diffuse_reflectance 0.5, specular_reflectance 1, distribution \"beckmann\", alpha 0.1 (alpha_u, alpha_v), "
     "int_ior \"polypropylene\", ext_ior \"air\", sample_visible true",
     "as Mitsuba 3's unpolarized variants evaluate it", mts_bsdf_pplastic},
    {"bsdf", "hair", MTS_PLUGIN_NO, "-", "", NULL},
    {"bsdf", "measured", MTS_PLUGIN_NO, "-", "measured RGL BSDFs", NULL},
    {"bsdf", "measured_polarized", MTS_PLUGIN_NO, "-", "polarized variants only", NULL},
    {"bsdf", "polarizer", MTS_PLUGIN_STANDIN, "transmittance 1 (constant); theta, polarizing unused",
     "as Mitsuba 3's RGB variants render it: a null surface passing half the light", mts_bsdf_polarizer},
    {"bsdf", "retarder", MTS_PLUGIN_NO, "-", "polarization is not modelled", NULL},
    {"bsdf", "circular", MTS_PLUGIN_NO, "-", "polarization is not modelled", NULL},
    {"bsdf", "roughdiffuse", MTS_PLUGIN_OWN, "reflectance 0.5, alpha 0.2, use_fast_approx false",
     "Mitsuba 0.6's (Oren-Nayar); Mitsuba 3 has no such plugin", mts_bsdf_roughdiffuse},
    {"bsdf", "phong", MTS_PLUGIN_OWN, "exponent 30, specular_reflectance 0.2, diffuse_reflectance 0.5",
     "Mitsuba 0.6's; Mitsuba 3 has no such plugin", mts_bsdf_phong},

    /* ---- emitters ---- */
    {"emitter", "area", MTS_PLUGIN_YES, "radiance 1 (rgb or texture)",
     "inside a shape, or at the top level with an id and referenced from shapes", mts_emitter_area},
    {"emitter", "point", MTS_PLUGIN_YES, "intensity 1, position (or to_world)", "", mts_emitter_point},
    {"emitter", "spot", MTS_PLUGIN_YES, "intensity 1, cutoff_angle 20, beam_width 3/4 cutoff_angle, texture, to_world",
     "", mts_emitter_spot},
    {"emitter", "directional", MTS_PLUGIN_YES, "irradiance 1, direction (or to_world)", "", mts_emitter_directional},
    {"emitter", "constant", MTS_PLUGIN_YES, "radiance 1", "", mts_emitter_constant},
    {"emitter", "envmap", MTS_PLUGIN_YES, "filename, scale 1, to_world", "", mts_emitter_envmap},
    {"emitter", "projector", MTS_PLUGIN_YES,
     "irradiance 1 (rgb or texture), scale 1, fov (fov_axis \"x\") or focal_length \"50mm\", to_world", "",
     mts_emitter_projector},
    {"emitter", "directionalarea", MTS_PLUGIN_NO, "-", "", NULL},
    {"emitter", "sunsky", MTS_PLUGIN_NO, "-", "", NULL},

    /* ---- shapes ---- */
    {"shape", "obj", MTS_PLUGIN_YES, "filename, face_normals false, flip_normals false, flip_tex_coords true, to_world",
     "", mts_shape_obj},
    {"shape", "ply", MTS_PLUGIN_YES, "filename, face_normals false, flip_normals false, to_world", "", mts_shape_ply},
    {"shape", "serialized", MTS_PLUGIN_YES, "filename, shape_index 0, face_normals false, flip_normals false, to_world",
     "", mts_shape_serialized},
    {"shape", "sphere", MTS_PLUGIN_YES, "center (0,0,0), radius 1, flip_normals false, to_world", "exact (analytic)",
     mts_shape_sphere},
    {"shape", "disk", MTS_PLUGIN_YES, "flip_normals false, to_world", "exact (analytic)", mts_shape_disk},
    {"shape", "rectangle", MTS_PLUGIN_YES, "flip_normals false, to_world", "", mts_shape_rectangle},
    {"shape", "cube", MTS_PLUGIN_YES, "flip_normals false, to_world", "", mts_shape_cube},
    {"shape", "cylinder", MTS_PLUGIN_YES, "p0 (0,0,0), p1 (0,0,1), radius 1, flip_normals false, to_world",
     "exact (analytic)", mts_shape_cylinder},
    {"shape", "shapegroup", MTS_PLUGIN_YES, "nested shapes", "", mts_shape_shapegroup},
    {"shape", "instance", MTS_PLUGIN_YES, "a referenced shapegroup, to_world", "", mts_shape_instance},
    {"shape", "bsplinecurve", MTS_PLUGIN_YES, "filename, flip_normals false, to_world (radii not scaled)",
     "Embree's round B-spline curves, back faces culled, as Mitsuba 3; not an area emitter", mts_shape_curve},
    {"shape", "linearcurve", MTS_PLUGIN_YES, "filename, flip_normals false, to_world (radii not scaled)",
     "Embree's round linear curves, back faces culled, as Mitsuba 3; not an area emitter", mts_shape_curve},
    {"shape", "sdfgrid", MTS_PLUGIN_YES, "filename (.vol), normals \"smooth\", to_world",
     "exact per-voxel intersection; not an area emitter, nor a specular chain vertex", mts_shape_sdfgrid},
    {"shape", "ellipsoids", MTS_PLUGIN_NO, "-", "", NULL},
    {"shape", "ellipsoidsmesh", MTS_PLUGIN_NO, "-", "", NULL},
    {"shape", "sdf", MTS_PLUGIN_OWN, "a tree of nested sdf nodes", "specula's signed distance fields", mts_shape_sdf},

    /* ---- textures ---- */
    {"texture", "bitmap", MTS_PLUGIN_YES, "filename, filter_type \"bilinear\", wrap_mode \"repeat\", raw false, to_uv",
     "images: OpenEXR, PNG, JPEG, BMP (uncompressed); format (storage precision), max_anisotropy and cache are "
     "accepted and ignored (texels are float)", mts_texture_bitmap},
    {"texture", "checkerboard", MTS_PLUGIN_YES, "color0 0.4, color1 0.2, to_uv", "", mts_texture_checkerboard},
    {"texture", "rawconstant", MTS_PLUGIN_YES, "value 1 (float or vector)", "", mts_texture_rawconstant},
    {"texture", "mesh_attribute", MTS_PLUGIN_YES, "name (\"vertex_*\" or \"face_*\"), scale 1",
     "PLY attributes as Mitsuba names them; read by BSDF parameters (elsewhere black)", mts_texture_mesh_attribute},
    {"texture", "volume", MTS_PLUGIN_NO, "-", "", NULL},

    /* ---- sensors ---- */
    {"sensor", "perspective", MTS_PLUGIN_YES,
     "to_world, fov (fov_axis \"x\") or focal_length \"50mm\", near_clip 0.01, far_clip 10000", "", NULL},
    {"sensor", "thinlens", MTS_PLUGIN_YES, "as perspective, aperture_radius (required), focus_distance far_clip",
     "bdpt's and specular NEE's strategies that join the camera are off with a lens", NULL},
    {"sensor", "orthographic", MTS_PLUGIN_YES, "to_world, near_clip 0.01, far_clip 10000", "", NULL},
    {"sensor", "radiancemeter", MTS_PLUGIN_NO, "-", "", NULL},
    {"sensor", "irradiancemeter", MTS_PLUGIN_NO, "-", "", NULL},
    {"sensor", "distant", MTS_PLUGIN_NO, "-", "", NULL},
    {"sensor", "batch", MTS_PLUGIN_NO, "-", "", NULL},

    /* ---- films and filters ---- */
    {"film", "hdrfilm", MTS_PLUGIN_YES, "width 768, height 576, crop_offset_x/y 0, crop_width/height, rfilter",
     "pixel_format and component_format are read and ignored (EXR RGB float)", NULL},
    {"film", "specfilm", MTS_PLUGIN_NO, "-", "", NULL},
    {"film", "ldrfilm", MTS_PLUGIN_OWN, "as hdrfilm", "Mitsuba 0.6's; the image is written as by hdrfilm", NULL},
    {"rfilter", "box", MTS_PLUGIN_YES, "-", "", NULL},
    {"rfilter", "tent", MTS_PLUGIN_YES, "radius 1", "", NULL},
    {"rfilter", "gaussian", MTS_PLUGIN_YES, "stddev 0.5", "", NULL},
    {"rfilter", "mitchell", MTS_PLUGIN_STANDIN, "-", "rendered with the gaussian filter (stddev 0.5), with a warning",
     NULL},
    {"rfilter", "catmullrom", MTS_PLUGIN_STANDIN, "-", "rendered with the gaussian filter (stddev 0.5), with a warning",
     NULL},
    {"rfilter", "lanczos", MTS_PLUGIN_STANDIN, "-", "rendered with the gaussian filter (stddev 0.5), with a warning",
     NULL},

    /* ---- samplers ---- */
    {"sampler", "independent", MTS_PLUGIN_YES, "sample_count 4, seed 0",
     "every sampler is specula's own stratified, scrambled sequence", NULL},
    {"sampler", "stratified", MTS_PLUGIN_YES, "sample_count 4, seed 0", "", NULL},
    {"sampler", "multijitter", MTS_PLUGIN_YES, "sample_count 4, seed 0", "", NULL},
    {"sampler", "orthogonal", MTS_PLUGIN_YES, "sample_count 4, seed 0", "", NULL},
    {"sampler", "ldsampler", MTS_PLUGIN_YES, "sample_count 4, seed 0", "", NULL},
    {"sampler", "halton", MTS_PLUGIN_OWN, "sample_count 4, seed 0", "Mitsuba 0.6's", NULL},
    {"sampler", "hammersley", MTS_PLUGIN_OWN, "sample_count 4, seed 0", "Mitsuba 0.6's", NULL},
    {"sampler", "sobol", MTS_PLUGIN_OWN, "sample_count 4, seed 0", "Mitsuba 0.6's", NULL},

    /* ---- integrators ---- */
    {"integrator", "path", MTS_PLUGIN_YES, "max_depth -1, rr_depth 5, hide_emitters false", "", mts_integrator_path},
    {"integrator", "prb", MTS_PLUGIN_YES, "as path", "rendered by path", mts_integrator_path},
    {"integrator", "volpath", MTS_PLUGIN_YES, "max_depth -1, rr_depth 5, hide_emitters false", "", mts_integrator_volpath},
    {"integrator", "volpathmis", MTS_PLUGIN_YES, "as volpath", "rendered by volpath", mts_integrator_volpath},
    {"integrator", "direct", MTS_PLUGIN_YES, "emitter_samples, bsdf_samples (read, not used)",
     "path with max_depth 2; Mitsuba counts each of emitter_samples delta-light samples at full weight", mts_integrator_direct},
    {"integrator", "aov", MTS_PLUGIN_YES, "aovs (albedo, depth, position, sh_normal), a nested integrator",
     "other AOV types are refused", mts_integrator_nested},
    {"integrator", "moment", MTS_PLUGIN_YES, "a nested integrator", "the nested integrator's image only", mts_integrator_nested},
    {"integrator", "stokes", MTS_PLUGIN_YES, "a nested integrator", "the nested integrator's image only", mts_integrator_nested},
    {"integrator", "ptracer", MTS_PLUGIN_YES, "max_depth -1, rr_depth 5, hide_emitters false",
     "light tracing (bdpt's t = 1 strategies); samples_per_pass read and unused", mts_integrator_ptracer},
    {"integrator", "depth", MTS_PLUGIN_NO, "-", "", NULL},
    {"integrator", "prbvolpath", MTS_PLUGIN_NO, "-", "", NULL},
    {"integrator", "bdpt", MTS_PLUGIN_OWN, "max_depth -1, rr_depth 5, mis_balance false",
     "Mitsuba 0.6 had one; Mitsuba 3 has not", mts_integrator_bdpt},
    {"integrator", "ipt", MTS_PLUGIN_OWN, "max_depth -1", "implicit path tracing (no NEE)", mts_integrator_ipt},

    /* ---- media and phase functions ---- */
    {"medium", "homogeneous", MTS_PLUGIN_YES,
     "sigma_t 1 and albedo 0.75 (or sigma_a, sigma_s), scale 1, sample_emitters true, phase",
     "albedo may be a volume; sigma_t a constvolume", mts_medium_homogeneous},
    {"medium", "heterogeneous", MTS_PLUGIN_YES,
     "sigma_t 1 (volume or value), albedo 0.75 (volume or value), scale 1, sample_emitters true, phase",
     "vacuum outside the sigma_t volume's bounds, as in Mitsuba; free flight by exact optical depth "
     "(regular tracking) instead of delta tracking: the same distribution; has_spectral_extinction ignored",
     mts_medium_heterogeneous},
    {"phase", "isotropic", MTS_PLUGIN_YES, "-", "", mts_phase_isotropic},
    {"phase", "hg", MTS_PLUGIN_YES, "g 0.8", "", mts_phase_hg},
    {"phase", "rayleigh", MTS_PLUGIN_NO, "-", "", NULL},
    {"phase", "blendphase", MTS_PLUGIN_NO, "-", "", NULL},
    {"phase", "tabphase", MTS_PLUGIN_NO, "-", "", NULL},
    {"phase", "sggx", MTS_PLUGIN_NO, "-", "", NULL},
    {"volume", "constvolume", MTS_PLUGIN_YES, "value 1 (float or rgb), to_world", "", mts_volume_constvolume},
    {"volume", "gridvolume", MTS_PLUGIN_YES,
     "filename (.vol, 1 or 3 channels), filter_type \"trilinear\", wrap_mode \"clamp\", to_world, "
     "use_grid_bbox false",
     "raw and accel accepted, no effect in RGB; 6-channel grids are not read", mts_volume_gridvolume},
};

const mts_plugin *mts_plugin_list(int *n)
{
    *n = (int)(sizeof plugins / sizeof plugins[0]);
    return plugins;
}

static const char *status_text(mts_plugin_status s)
{
    switch (s) {
    case MTS_PLUGIN_YES:
        return "yes";
    case MTS_PLUGIN_NO:
        return "**no**";
    case MTS_PLUGIN_OWN:
        return "yes (not in Mitsuba 3)";
    case MTS_PLUGIN_STANDIN:
        return "stand-in";
    }
    return "?";
}

int mts_plugins_markdown(FILE *out)
{
    int n;
    const mts_plugin *p = mts_plugin_list(&n);
    int yes = 0, no = 0, standin = 0;
    for (int i = 0; i < n; ++i) {
        yes += p[i].status == MTS_PLUGIN_YES;
        no += p[i].status == MTS_PLUGIN_NO;
        standin += p[i].status == MTS_PLUGIN_STANDIN;
    }
    fprintf(out, "# Mitsuba 3 plugins in specula\n\n");
    fprintf(out, "Generated from the loader's plugin table (`src/io/mitsuba_plugin_list.c`) by\n"
                 "`tests/test_plugins.c` (`SPC_WRITE_PLUGINS=1 build/test_plugins` rewrites this file; the test\n"
                 "fails when the file and the table differ, or when the loader does not accept a plugin marked\n"
                 "yes or does not refuse one marked no). Do not edit by hand.\n\n");
    fprintf(out,
            "Of %d Mitsuba 3 plugins listed, specula reads %d, renders %d with a stand-in (and a warning)\n"
            "and refuses %d with an error naming the plugin; %d more are specula's own or Mitsuba 0.6's.\n"
            "Parameters are given with their defaults.\n",
            yes + no + standin, yes, standin, no, n - yes - no - standin);
    const char *cat = "";
    for (int i = 0; i < n; ++i) {
        if (strcmp(cat, p[i].category) != 0) {
            cat = p[i].category;
            fprintf(out, "\n## %s\n\n| plugin | specula | parameters read | notes |\n|---|---|---|---|\n", cat);
        }
        fprintf(out, "| `%s` | %s | %s | %s |\n", p[i].name, status_text(p[i].status), p[i].params, p[i].note);
    }
    static const char *const kind_names[] = {"boolean", "integer", "float", "string"};
    fprintf(out, "\n## specula's own properties\n\n"
                 "Mitsuba 3 refuses a scene whose plugin has a property it does not read (\"unreferenced\n"
                 "property\"). Each property below may therefore also be written as a `<default>` inside the\n"
                 "plugin element, which Mitsuba 3 accepts and ignores, and specula reads as the property:\n"
                 "`<integrator type=\"path\"><default name=\"specular_nee\" value=\"angular\"/></integrator>`.\n"
                 "specula's `sdf` shapes have no such form: a scene with them loads in specula only.\n\n"
                 "| plugin | property | type | meaning |\n|---|---|---|---|\n");
    int nown;
    const mts_own_property *own = mts_own_property_list(&nown);
    for (int i = 0; i < nown; ++i) {
        const mts_own_property *o = &own[i];
        fprintf(out, "| %s | `%s` | %s | %s |\n", o->category, o->name,
                o->kind <= MTS_STRING ? kind_names[o->kind] : "?", o->meaning);
    }
    return ferror(out) ? -1 : 0;
}
