// Analytic test shapes, outward oriented (SPEC §1 conventions).
#pragma once

#include "lib/mesh.h"

namespace meshgauge {

// Regular counter-clockwise polygon with `segments` vertices on the circle of
// radius `radius` centred at the origin (2D).
Mesh MakeCircle(double radius, int segments);

// Geodesic icosphere of radius `radius`: every icosahedron edge split into
// `frequency` parts, vertices projected to the sphere; edge length about
// 1.05 * radius / frequency. frequency >= 1.
Mesh MakeIcosphere(double radius, int frequency);

// Torus around z with tube centre radius R and tube radius r, nu x nv quads
// split into triangles.
Mesh MakeTorus(double major_radius, double minor_radius, int nu, int nv);

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
