/*
 * device/device.h: render devices other than the CPU threads of render/driver.c. The driver keeps
 * the pass structure (one pass = one sample per pixel of the window, committed to the film in
 * order); a device renders whole batches of passes into the driver's batch buffer, so the film,
 * seeds, --time, progress, checkpoints and cancellation behave as on the CPU.
 *
 * The opencl device (opencl.c, kernels in kernels.cl) renders scenes made only of what its
 * kernels support: SDF shapes, spheres, small triangle meshes (rectangles, cubes), diffuse,
 * conductor and dielectric BSDFs with constant parameters, area lights on spheres and meshes,
 * the perspective camera, the path and bdpt integrators. Anything else is refused by name.
 */
#ifndef SPC_DEVICE_DEVICE_H
#define SPC_DEVICE_DEVICE_H

#include <stdint.h>

#include "core/error.h"
#include "integrator/integrator.h"

typedef struct spc_cl_renderer spc_cl_renderer;

/* Parses a device name: "cpu" (or NULL, "") gives *opencl = false; "opencl" or "opencl:N" (N the
 * device's index in `specula info --devices`, default 0) gives *opencl = true and *index. False
 * for anything else. */
bool spc_device_parse(const char *name, bool *opencl, int *index);

/* Checks that the device supports everything the render uses (scene, integrator, options) and
 * sets it up: flattens the scene, compiles the kernels, uploads the buffers. batch_passes is the
 * largest batch spc_cl_render_passes will be asked for. SPC_ERR_PLUGIN with "opencl device: ...
 * not supported" for what it cannot render, or when specula was built without OpenCL or no device
 * of that index exists; SPC_ERR_ACCEL when OpenCL fails. *out is freed with spc_cl_destroy. */
spc_status spc_cl_create(const spc_render_ctx *ctx, int device_index, bool aovs, spc_cl_renderer **out,
                         spc_error *err);
void spc_cl_destroy(spc_cl_renderer *r);

/* Renders passes pass0 .. pass0 + npasses - 1 into buf (npasses blocks of width x height pixels of
 * the window, stride doubles per pixel, RGB first), light-tracing splats included. Non-finite
 * estimates are replaced by 0 and counted in *invalid; the rays traced are added to *rays. */
spc_status spc_cl_render_passes(spc_cl_renderer *r, int pass0, int npasses, uint64_t seed, double *buf, int stride,
                                uint64_t *invalid, uint64_t *rays, spc_error *err);

/* The OpenCL platforms and devices found, one line each ("opencl:N  platform / device"), or a line
 * saying why there are none; the caller frees the string. */
char *spc_cl_describe_devices(void);

#endif
