// Pictures of a mesh coloured by a value per vertex (e.g. the SDF) or per
// face: one orthographic primary ray per pixel through the mesh's Embree BVH
// (3D), or the curve drawn in its plane (2D). Lambert shading (two-sided);
// the value at each pixel is interpolated linearly (barycentric) over the
// hit triangle from vertex values, or the face's own value (flat), and
// coloured by a ColorScale, grey where it is missing; optional outlines
// around marked faces (thin regions), along the contour of the pixels'
// values (the iso-line t = outline_below) rather than the faces' edges.
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/colormap.h"
#include "lib/core/image.h"
#include "lib/core/mesh.h"
#include "lib/core/sdf_types.h"

namespace meshgauge {

// A camera direction: the rays travel along `direction`; `up` is the
// picture's upward direction (made orthogonal to it).
struct View {
  std::string name;
  Vec3 direction;
  Vec3 up;
};

// front, back, top and oblique for a mesh whose up axis is `up_axis`
// (1: y, 2: z). z up: front looks along +y, top along -z; y up: front looks
// along -z, top along -y. The oblique view looks down from the front right.
std::vector<View> StandardViews(int up_axis);

struct RenderOptions {
  int width = 500, height = 400;  // pixels per view, 16..8192 each.
  Rgb background = {255, 255, 255};
  // Where the values are: kVertices, #V values interpolated per pixel over
  // each triangle; kFaces, #F values, one flat value per face (a quad's two
  // triangles alike).
  SampleSet samples = SampleSet::kVertices;
  // NaN: a pixel of a marked face is marked. Otherwise only where its value
  // is below this (t_min), so that the outline follows the iso-line of the
  // interpolated values inside a face, not the face's edges (a long sliver
  // triangle with one thin corner is not outlined along its whole length).
  double outline_below = std::numeric_limits<double>::quiet_NaN();
};

struct RenderedView {
  std::string name;
  Image image;
  std::vector<int32_t> face;  // per pixel: the mesh face seen, -1 for none.
  std::vector<double> value;  // per pixel: the value coloured, NaN for none.
};

// values: #V or #F as options.samples says (NaN: no value). outline:
// empty, or #F marks (-1: unmarked); unmarked pixels (faces or background)
// within 2 pixels of a marked pixel are drawn in kThinOutline, so marked
// pixels keep their colours.
// 3D: one picture per view, framing the bounding sphere. 2D: one picture,
// "plane", of the curve seen from +z (x right, y up), `views` ignored.
// Precondition: mesh validated. Errors: InvalidArgument for sizes; Internal
// from Embree.
absl::StatusOr<std::vector<RenderedView>> RenderViews(
    const Mesh& mesh, const std::vector<double>& values,
    const ColorScale& scale, const std::vector<int32_t>& outline,
    const std::vector<View>& views, const RenderOptions& options);

}  // namespace meshgauge
