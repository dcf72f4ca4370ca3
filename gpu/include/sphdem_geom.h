/* sphdem_geom.h - host geometry for creating SPH particles: ASCII STL meshes, dummy-wall layers behind a mesh,
 * merging of close points, exclusion of points near spheres (fix sph/wall, fix sph/fill). Plain C, no engine. */
#ifndef SPHDEM_GEOM_H
#define SPHDEM_GEOM_H

#include <stddef.h>

#include "sphdem.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One triangle; n is the unit normal by the vertex winding (right-hand rule: (v1-v0) x (v2-v0)), which by this
 * package's convention points INTO the fluid (the container's inside); the wall layers go to the other side. */
typedef struct {
  double v[3][3];
  double n[3];
} sphdem_facet;

typedef struct {
  sphdem_facet *f;
  long nfacet;
  long ndegenerate;  /* facets of zero area skipped by the reader */
  long ndisagree;    /* facets whose written "facet normal" points against the winding's normal */
} sphdem_mesh;

/* A growing list of points, x[3*i .. 3*i+2]. */
typedef struct {
  double *x;
  long n, cap;
} sphdem_points;

/* Reads an ASCII STL file (binary STL is refused with a message). Returns SPHDEM_OK, or SPHDEM_ERR_ARG with msg
 * naming the file and line, SPHDEM_ERR_ALLOC. *m is zeroed first; free with sphdem_mesh_free. */
int sphdem_stl_read(const char *path, sphdem_mesh *m, char *msg, size_t msglen);
/* The same from a string (the unit tests). */
int sphdem_stl_parse(const char *text, const char *name, sphdem_mesh *m, char *msg, size_t msglen);
void sphdem_mesh_free(sphdem_mesh *m);
/* x -> scale * x + move (LIGGGHTS fix mesh/surface: scale, then move); scale > 0 keeps the normals */
void sphdem_mesh_transform(sphdem_mesh *m, double scale, const double move[3]);
/* reverse every facet (normals to the other side) */
void sphdem_mesh_flip(sphdem_mesh *m);
/* turn each facet so that its normal faces point p (n . (p - centroid) >= 0); returns how many were turned */
long sphdem_mesh_orient(sphdem_mesh *m, const double p[3]);
void sphdem_mesh_bbox(const sphdem_mesh *m, double lo[3], double hi[3]);

/* Dummy-wall points behind a mesh: each facet is sampled on an in-plane square lattice of spacing dx whose origin
 * is the projection of `origin` onto the facet's plane (coplanar facets share one lattice), over the triangle
 * extended by layers*dx across every edge another facet touches (open edges are not extended); each sample gives
 * `layers` points at depths (k + 1/2) dx, k = 0 .. layers-1, on the side opposite the normal. A point is dropped
 * when it lies on the fluid side of (or on) its nearest facet, or when it is farther than layers*dx from the mesh
 * and deeper than layers*dx behind a facet whose extended triangle it lies over. A point from a facet that is
 * not its nearest facet is a filler, kept only where no other point is within 0.9 dx (facets narrower than dx);
 * the others closer than dx/2 to an earlier one are merged (the first is kept). The result is deterministic (file order). Appends to *out. */
int sphdem_wall_from_mesh(const sphdem_mesh *m, double dx, int layers, const double origin[3], sphdem_points *out,
                          char *msg, size_t msglen);

/* Removes every point closer than dmin to an earlier one (the first is kept; order kept). Returns the count removed
 * (>= 0) or -SPHDEM_ERR_ALLOC. */
long sphdem_points_merge(sphdem_points *p, double dmin);
/* Appends to dst each point of src not closer than dmin to a point of dst (including those appended before it).
 * Returns the count left out (>= 0) or -SPHDEM_ERR_ALLOC. */
long sphdem_points_merge_into(sphdem_points *dst, const sphdem_points *src, double dmin);
/* Removes every point closer than r_j + gap - tol to one of the spheres xr[4*j .. 4*j+3] = (x, y, z, r), j < ns.
 * Returns the count removed (>= 0) or -SPHDEM_ERR_ALLOC. */
long sphdem_points_exclude(sphdem_points *p, const double *xr, long ns, double gap, double tol);
/* Keeps the points on the fluid side of mesh m (the side its normals point to) at least gap from it: a point within
 * max(1.5 dx, gap + dx/2) of the mesh takes the side of its nearest facet (sphdem_wall_from_mesh's tie rule); the
 * points farther away take the side of the near points next to them on their lattice of spacing dx (the points are
 * such a lattice, e.g. a fill), or, where none is next to them, of the nearest facet over the whole mesh. Returns the
 * count removed (>= 0) or -SPHDEM_ERR_ALLOC. */
long sphdem_points_clip_mesh(sphdem_points *p, const sphdem_mesh *m, double dx, double gap);
int sphdem_points_push(sphdem_points *p, double x, double y, double z);
void sphdem_points_free(sphdem_points *p);

#ifdef __cplusplus
}
#endif
#endif
