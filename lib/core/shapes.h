// Analytic test shapes, outward oriented (SPEC §1 conventions).
#pragma once

#include <array>
#include <functional>

#include "lib/core/mesh.h"

namespace meshgauge {

// Regular counter-clockwise polygon with `segments` vertices on the circle of
// radius `radius` centred at the origin (2D).
Mesh MakeCircle(double radius, int segments);

// Geodesic icosphere of radius `radius`: every icosahedron edge split into
// `frequency` parts, vertices projected to the sphere; edge length about
// 1.05 * radius / frequency. frequency >= 1.
Mesh MakeIcosphere(double radius, int frequency);

// Closed cone of height 1 over the unit circle in z = 0, as CAD exports cap
// it: apex 0 at (0, 0, 1), base centre 1 at the origin, `rim` vertices 2..
// on the circle, and two fans of triangles (apex, rim i, rim i + 1) and
// (centre, rim i + 1, rim i): the apex and the centre are in `rim`
// triangles each. rim >= 3.
Mesh MakeFanCone(int rim);

// Closed cylinder of height 1 over the unit circle in z = 0, capped as CAD
// exports cap it: cap centres 0 (z = 0) and 1 (z = 1), `rim` vertices per
// circle (2 + i at z = 0, 2 + rim + i at z = 1), fans of triangles around
// each centre and a wall of quads split into two triangles. rim >= 3.
Mesh MakeFanCylinder(int rim);

// Torus around z with tube centre radius R and tube radius r, nu x nv quads
// split into triangles.
Mesh MakeTorus(double major_radius, double minor_radius, int nu, int nv);

// The boundary of a union of axis-aligned voxels: cell (i, j, k) of
// cells[0] x cells[1] x cells[2] is [i, i+1] x [j, j+1] x [k, k+1] times
// `spacing` when filled(i, j, k). Every voxel face between a filled and an
// empty cell is a quad (two triangles unless quads), outward, with shared
// vertices. The result is closed; it is a manifold when no two filled cells
// touch along an edge or a corner only.
Mesh MakeVoxelSolid(const std::array<int, 3>& cells,
                    const std::array<double, 3>& spacing,
                    const std::function<bool(int, int, int)>& filled,
                    bool quads = false);

// Axis-aligned box [0,sx] x [0,sy] x [0,sz], each face a grid of cells of at
// most `cell` mesh units, each cell two triangles or (quads = true) a quad.
Mesh MakeBox(double sx, double sy, double sz, double cell, bool quads = false);

// 2D square [-a/2, a/2]^2 (counter-clockwise, region 0, INWARD) with a
// circular hole of radius r at the centre (clockwise so its normal points out
// of the solid, into the hole; region 1, OUTWARD; an odd number of vertices,
// the first at angle 0). Element size about h; each side of the square has
// ceil(side / h) segments (at least 2).
Mesh MakeHollowSquare(double side, double hole_radius, double h);

}  // namespace meshgauge
