// Pictures of a mesh coloured by a per-vertex value (e.g. the SDF): one
// orthographic primary ray per pixel through the mesh's Embree BVH (3D), or
// the curve drawn in its plane (2D). Lambert shading (two-sided), the value
// interpolated linearly over the hit triangle and coloured by a ColorScale,
// grey where a vertex of the face has no value, and optional outlines
// around marked faces (thin regions).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "lib/core/colormap.h"
#include "lib/core/image.h"
#include "lib/core/mesh.h"

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
};

struct RenderedView {
  std::string name;
  Image image;
  std::vector<int32_t> face;  // per pixel: the mesh face seen, -1 for none.
};

// values: #V (NaN: no value). outline: empty, or #F marks (-1: unmarked);
// unmarked pixels (faces or background) within 2 pixels of a marked face
// are drawn in kThinOutline, so marked faces keep their colours.
// 3D: one picture per view, framing the bounding sphere. 2D: one picture,
// "plane", of the curve seen from +z (x right, y up), `views` ignored.
// Precondition: mesh validated. Errors: InvalidArgument for sizes; Internal
// from Embree.
absl::StatusOr<std::vector<RenderedView>> RenderViews(
    const Mesh& mesh, const std::vector<double>& values,
    const ColorScale& scale, const std::vector<int32_t>& outline,
    const std::vector<View>& views, const RenderOptions& options);

}  // namespace meshgauge
