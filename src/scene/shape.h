/*
 * scene/shape.h: the shapes of a scene, in world space. Tagged union, dispatched in shape.c;
 * analytic shapes are intersected exactly in double precision (Embree user geometry), meshes
 * through Embree's triangles.
 *
 * XML (Mitsuba 3 conventions):
 *   sphere     center (0,0,0), radius (1), to_world (uniform scale and translation only)
 *   rectangle  [-1,1]^2 in z = 0, normal +z, uv = ((x+1)/2, (y+1)/2); stored as a 2-triangle mesh
 *   cube       [-1,1]^3, outward normals; stored as a 12-triangle mesh with uvs per face
 *   disk       unit disk in z = 0, normal +z (exact)
 *   cylinder   radius (1), p0 (0,0,0), p1 (0,0,1), open, outward normals (exact)
 *   obj, ply, serialized  filename, face_normals (false), flip_normals (false), to_world
 *   sdf        one nested <sdf> tree (scene/sdf.h lists its nodes), to_world (a similarity)
 *   linearcurve, bsplinecurve  filename, to_world (scene/curve.h); not emitters, not chain vertices
 *   sdfgrid    filename (a one-channel .vol grid over [0,1]^3), normals ("smooth" | "analytic"),
 *              to_world (scene/sdfgrid.h); not an area emitter, never a specular chain vertex
 * Every shape: flip_normals, an optional bsdf (default: diffuse 0.5), an optional area emitter,
 * and the per-shape booleans caustic_caster, caustic_receiver (+ _single / _multi variants).
 */
#ifndef SPC_SCENE_SHAPE_H
#define SPC_SCENE_SHAPE_H

#include "core/math.h"
#include "core/warp.h"
#include "scene/hit.h"
#include "scene/mesh.h"

struct spc_bsdf;
struct spc_emitter;
struct spc_sdf;
struct spc_curve;
struct spc_sdfgrid;

typedef enum spc_shape_type {
    SPC_SHAPE_MESH,
    SPC_SHAPE_SPHERE,
    SPC_SHAPE_DISK,
    SPC_SHAPE_CYLINDER,
    SPC_SHAPE_SDF,
    SPC_SHAPE_CURVE,
    SPC_SHAPE_SDFGRID
} spc_shape_type;

/* Meshes keep their triangles' frames (spc_shape.tri_frame, 152 bytes a triangle) up to this many
 * triangles, a mesh and a scene (spc_scene_finalize drops them from the meshes past the scene's
 * budget): at most 9.5 MiB. Those are the walls, boxes and quads that most rays of a room
 * hit, where a hit's normalizations were a tenth of the path tracer's time (cornell box); big meshes
 * are hit by fewer rays per triangle and keep their memory. */
#define SPC_MESH_FRAME_MAX_TRIS 65536
/* The doubles a triangle's entry takes in spc_shape.tri_frame. */
#define SPC_TRI_FRAME_STRIDE 19
/* How far, per coordinate and relative to the corners' largest coordinate, triangle 1's corner off
 * the shared edge may be from o + e1 + e2 for a pair to be sampled as a parallelogram
 * (spc_mesh_para): one float epsilon, an eighth of a hit's error bound (8 float epsilons), so the
 * points drawn in triangle 1 lie on it well within that bound. Vertices that went through a
 * transform in float keep a rectangle's corners within it. */
#define SPC_PARA_TOL 0x1p-23

/* Per-shape caustic flags (Mitsuba properties used by the caustics papers' scenes). */
enum {
    SPC_CAUSTIC_CASTER = 1u << 0,         /* may be a vertex of a specular chain (default for specular shapes) */
    SPC_CAUSTIC_RECEIVER = 1u << 1,       /* specular NEE starts at its diffuse points (default) */
    SPC_CAUSTIC_CASTER_SINGLE = 1u << 2,  /* only in chains of one vertex */
    SPC_CAUSTIC_CASTER_MULTI = 1u << 3,   /* only in chains of more than one vertex */
    SPC_CAUSTIC_FLAGS_EXPLICIT = 1u << 8  /* the file said something: do not apply defaults */
};

/* A mesh of two triangles that form a parallelogram, sampled as one (spc_shape_sample_area): the
 * point o + a e1 + b e2 for (a, b) uniform in the unit square, uniform by area with no triangle to
 * pick. o is triangle 0's corner off the shared edge and e1, e2 run from it to the shared edge's two
 * ends; a + b <= 1 lies in triangle 0, a + b > 1 in triangle 1 (whose corner off the edge is
 * o + e1 + e2 within SPC_PARA_TOL). */
typedef struct spc_mesh_para {
    spc_vec3 o, e1, e2;
    spc_vec3 ng[2]; /* each triangle's unit normal, before flip_normals, as fill_mesh computes it */
    double mag;     /* the largest absolute coordinate of the four corners (the point's error bound) */
    /* for each triangle's vertex j, which of the point's three weights in that triangle is its
     * barycentric: 0 the corner off the shared edge, 1 the edge's end at o + e1, 2 the one at o + e2 */
    unsigned char role[2][3];
} spc_mesh_para;

typedef struct spc_shape {
    spc_shape_type type;
    char id[128];
    spc_mesh mesh;           /* MESH: world space */
    bool face_normals;       /* MESH: ignore vertex normals */
    spc_vec3 center;         /* SPHERE */
    double radius;           /* SPHERE, CYLINDER */
    double length;           /* CYLINDER: along local z */
    spc_mat4 to_world, to_local; /* DISK, CYLINDER, SPHERE (orientation for uv) */
    struct spc_sdf *sdf;     /* SDF: the field in world space (owned, freed by spc_shape_release) */
    struct spc_curve *curve; /* CURVE: control points in world space (owned, as sdf) */
    struct spc_sdfgrid *sdfgrid; /* SDFGRID: the grid and its to_world (owned, freed likewise) */
    bool flip_normals;
    const struct spc_bsdf *bsdf;
    const struct spc_emitter *emitter; /* area emitter, or NULL */
    unsigned caustic_flags;
    int interior_medium, exterior_medium; /* indices into scene->media, -1 for none */
    /* set by spc_shape_prepare: */
    double area;
    spc_distrib1d tri_distrib; /* MESH: triangle areas */
    /* MESH of at most SPC_MESH_FRAME_MAX_TRIS triangles: per triangle its unit geometric normal
     * (before flip_normals), the unit tangent of the shading frame on that normal as flip_normals
     * was when it was made (tri_frame_flip; zero where the frame falls back to spc_frame_from_n),
     * the frame's bitangent (that normal, flipped as flip_normals was, crossed with the tangent) and
     * the largest absolute coordinate of its vertices (the hit's error bound), and its three
     * vertices' positions (as doubles: the floats' values), SPC_TRI_FRAME_STRIDE doubles each, so
     * that a hit does not recompute them and reads one record rather than the indices and three
     * vertices (two dependent loads that miss the L1 cache behind the ray tracer); NULL for bigger
     * meshes. */
    double *tri_frame;
    bool tri_frame_flip;
    /* MESH of two triangles without vertex normals (or with face_normals) whose corners off the
     * shared edge mirror each other through its midpoint: sampled as the parallelogram para */
    bool has_para;
    spc_mesh_para para;
    /* set by spc_scene_finalize: a MESH whose BSDF reads no derivatives
     * (spc_bsdf_reads_derivatives), so that its shading hits may leave them out
     * (spc_shape_fill_hit_shading) */
    bool lazy_derivs;
    /* set by spc_scene_finalize: a SPHERE or MESH whose BSDF and emitter read no uv
     * (spc_bsdf_reads_uv, a constant radiance), so that a sphere's hits leave uv, b1 and b2 at zero
     * (fill_sphere: no acos and atan2 for coordinates nothing reads) and a mesh's shading records
     * (spc_shape_fill_hit_shading) leave uv at zero (no interpolation of the vertices' uvs) */
    bool uv_unread;
    /* set by spc_scene_finalize: the BSDF is a diffuse lobe of constant reflectance seen from either
     * side (spc_diffuse_view_const: diffuse, or twosided over diffuse, with constant reflectances),
     * with each side's frame sign and reflectance, so that the path wave shades this shape's diffuse
     * hits without the BSDF's dispatch or a texture lookup */
    bool diffuse_const;
    double diffuse_sign[2];
    spc_rgb diffuse_albedo[2];
    spc_vec3 bbox_min, bbox_max;
    /* Per-shape data of a specular solver (manifold/conic_solver.c: the mesh hierarchy), built on
     * first use and published atomically, so concurrent readers are safe. Its first member is its
     * destructor, void (*)(void *), which spc_shape_release calls. NULL until used. */
    void *solver_cache;
    /* The same for the exact chains on a normal-mapped plane (manifold/plane_chains.c). */
    void *plane_cache;
    /* The same for the exact chains through flat faces (manifold/flat_chains.c: the planar faces). */
    void *flat_cache;
    /* The same for the sphere fitted to a tessellated ball (manifold/fit_seeds.c). */
    void *fit_cache;
} spc_shape;

/* Area-measure sample of a point on a shape. */
typedef struct spc_shape_sample {
    spc_vec3 p, n; /* position and geometric normal (flip_normals applied) */
    spc_vec2 uv;
    double pdf;    /* area density (1/area for uniform sampling) */
    double err;    /* position error bound */
    int prim;
} spc_shape_sample;

/* Constructors used by the loaders (they set type and geometry; the caller sets bsdf, emitter,
 * flags). Each returns false with a message in err for invalid input (negative radius, singular
 * transform, NaN). spc_shape_init_mesh takes ownership of *m (and empties it) and transforms it to
 * world space. */
bool spc_shape_init_sphere(spc_shape *s, spc_vec3 center, double radius, const spc_mat4 *to_world,
                           const char *file, int line, int col, spc_error *err);
bool spc_shape_init_rectangle(spc_shape *s, const spc_mat4 *to_world, const char *file, int line, int col,
                              spc_error *err);
bool spc_shape_init_cube(spc_shape *s, const spc_mat4 *to_world, const char *file, int line, int col, spc_error *err);
bool spc_shape_init_disk(spc_shape *s, const spc_mat4 *to_world, const char *file, int line, int col, spc_error *err);
bool spc_shape_init_cylinder(spc_shape *s, spc_vec3 p0, spc_vec3 p1, double radius, const spc_mat4 *to_world,
                             const char *file, int line, int col, spc_error *err);
bool spc_shape_init_mesh(spc_shape *s, spc_mesh *m, const spc_mat4 *to_world, const char *file, int line, int col,
                         spc_error *err);
/* Takes ownership of sdf (also on failure: it is then destroyed) and finalizes it with node `root`
 * and to_world (see spc_sdf_finalize). */
bool spc_shape_init_sdf(spc_shape *s, struct spc_sdf *sdf, int root, const spc_mat4 *to_world, const char *file,
                        int line, int col, spc_error *err);
/* Takes ownership of curve (a heap spc_curve read by spc_curve_read, also on failure). */
bool spc_shape_init_curve(spc_shape *s, struct spc_curve *curve, const char *file, int line, int col,
                          spc_error *err);

/* Takes ownership of grid (also on failure). The grid already holds its to_world. */
bool spc_shape_init_sdfgrid(spc_shape *s, struct spc_sdfgrid *grid, const char *file, int line, int col,
                            spc_error *err);

/* Computes area, sampling tables and bounds. SPC_OK; SPC_ERR_NOMEM if the sampling table could not
 * be allocated; SPC_ERR_VALUE if the area is zero or not finite (or an SDF shape has no field). */
spc_status spc_shape_prepare(spc_shape *s);
/* Frees a mesh's kept triangle frames (spc_shape.tri_frame); hits are the same without them. */
void spc_shape_drop_frames(spc_shape *s);
void spc_shape_release(spc_shape *s);

/* Exact intersection for analytic shapes: the nearest t in (tmin, tmax), or false.
 * *u, *v receive surface coordinates passed back to spc_shape_fill_hit. */
bool spc_shape_intersect_analytic(const spc_shape *s, const spc_ray *r, double *t, double *u, double *v);
/* The texture frame of a hit as the shape builds its shading frame, sh = frame_from_ns(sh.n, T),
 * with derivatives with respect to the surface parameters (b1, b2) of hit.h: duv[j] = d uv / d b_j
 * and dT[j] = d T / d b_j. Normal maps on specular chain vertices need them (bsdf/normalmap.c).
 * False where no such derivatives exist: SDFs (their uv are not surface parameters) and the
 * probability-zero points where a shape's tangent is special (sphere poles, disk centre). */
bool spc_shape_texture_frame(const spc_hit *h, spc_vec2 duv[2], spc_vec3 *T, spc_vec3 dT[2]);
/* Fills every field of h for a hit of ray r at distance t on primitive prim with coordinates
 * (u, v) (barycentrics b1, b2 for triangles); on a sphere with uv_unread, uv, b1 and b2 are zero
 * (a mesh's uv_unread leaves them filled here). */
void spc_shape_fill_hit(const spc_shape *s, int prim, double u, double v, const spc_ray *r, double t, spc_hit *h);
/* spc_shape_fill_hit for shading: on a shape with lazy_derivs, every field but dpdu, dpdv, dndu,
 * dndv and n_unmapped (the same values as spc_shape_fill_hit's), which path tracing does not read
 * there, and uv (zero) where also uv_unread; on other shapes every field. */
void spc_shape_fill_hit_shading(const spc_shape *s, int prim, double u, double v, const spc_ray *r, double t,
                                spc_hit *h);
/* Prefetches for a coming fill of a hit on primitive prim of a mesh without a kept frame (a big
 * one): stage 1 asks for the triangle's index triple, stage 2 reads the indices and asks for the
 * vertices' positions, normals and uvs. Run stage 1 over a whole packet, then stage 2, then the
 * fills: such hits miss the cache, and this overlaps the misses of all lanes. Nothing is written;
 * other shapes do nothing. */
void spc_shape_prefetch_hit(const spc_shape *s, int prim);
void spc_shape_prefetch_vertices(const spc_shape *s, int prim);
/* spc_shape_fill_hit for a specular chain's vertex while a solver steps: on a mesh every field but
 * uv and the shading tangents sh.s, sh.t (zero; sh.n is filled), which the steps do not read; the
 * fields filled are spc_shape_fill_hit's values. Other shapes: every field. */
void spc_shape_fill_hit_chain(const spc_shape *s, int prim, double u, double v, const spc_ray *r, double t,
                              spc_hit *h);
/* Fills what spc_shape_fill_hit_chain left out of h (a hit on h->shape at h->prim, h->b1, h->b2):
 * afterwards h is byte for byte spc_shape_fill_hit's record. Does nothing on other shapes, whose
 * records are always whole. */
void spc_shape_hit_complete(spc_hit *h);
/* Fills what spc_shape_fill_hit_shading left out of h (a hit on h->shape at h->prim, h->b1,
 * h->b2): afterwards h is byte for byte spc_shape_fill_hit's record. Does nothing on shapes
 * without lazy_derivs, whose records are always whole. */
void spc_shape_hit_derivatives(spc_hit *h);

/* Uniform area sampling (meshes pick the triangle with u.x and reuse it, rescaled; a parallelogram
 * of two triangles, spc_shape.has_para, is sampled as one: o + u.x e1 + u.y e2). */
void spc_shape_sample_area(const spc_shape *s, spc_vec2 u, spc_shape_sample *out);
/* The sphere s's (u, v) at the unit direction dir from its centre (world space); zero where its
 * materials read no uv (uv_unread). */
spc_vec2 spc_sphere_uv(const spc_shape *s, spc_vec3 dir);

/* Solid-angle sampling from a reference point where the shape supports it (spheres: the cone of
 * directions subtended; SDFs: the cone of their bounding sphere traced to the first crossing, from
 * anywhere). Returns false if the shape has no such method (use area sampling) or ref is inside.
 * On success: the point on the shape, and pdf in SOLID ANGLE at ref; pdf = 0 means the method
 * applies but this sample found no point (an SDF direction that misses): no sample. With_uv false
 * (the caller does not read uv, e.g. an emitter of constant radiance), a sphere's uv is left
 * (0, 0) rather than computed; every other field is the same. */
bool spc_shape_sample_solid_angle(const spc_shape *s, spc_vec3 ref, spc_vec2 u, bool with_uv, spc_shape_sample *out);
/* Density (solid angle at ref) of the above for the point p on the shape seen from ref. */
double spc_shape_pdf_solid_angle(const spc_shape *s, spc_vec3 ref, spc_vec3 p);
/* Whether spc_shape_sample_solid_angle applies at ref: SDFs from anywhere (the bounding sphere's
 * cone, or all directions inside it), spheres from outside by a relative margin (inside, area
 * sampling is used). Inline: the sphere lights ask it per lane. */
static inline bool spc_shape_has_solid_angle_sampling(const spc_shape *s, spc_vec3 ref)
{
    if (s->type == SPC_SHAPE_SDF)
        return true;
    if (s->type != SPC_SHAPE_SPHERE)
        return false;
    return spc_length2(spc_sub(ref, s->center)) > s->radius * s->radius * (1.0 + 1e-9);
}

#endif
