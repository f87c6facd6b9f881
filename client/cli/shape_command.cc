#include <cmath>
#include <fstream>
#include <numbers>

#include "absl/strings/str_cat.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::cli {

absl::Status RunShape(const ShapeInput& in) {
  const std::string& out = in.out;
  const double h = in.size;
  const double r = in.radius;
  if (!(h > 0) || !(r > 0) || h > r) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--size and --radius must be > 0 with size <= radius, got ", h, ", ",
        r));
  }
  Mesh mesh;
  if (in.kind == "circle") {
    mesh = MakeCircle(
        r, static_cast<int>(std::ceil(2 * std::numbers::pi * r / h)));
  } else if (in.kind == "sphere") {
    mesh = MakeIcosphere(r, static_cast<int>(std::ceil(1.0515 * r / h)));
  } else if (in.kind == "torus") {
    mesh = MakeTorus(2 * r, r,
                     static_cast<int>(std::ceil(4 * std::numbers::pi * r / h)),
                     static_cast<int>(std::ceil(2 * std::numbers::pi * r / h)));
  } else if (in.kind == "hollow") {
    mesh = MakeHollowSquare(4 * r, r, h);
  } else {
    return absl::InvalidArgumentError(absl::StrCat(
        "unknown shape '", in.kind, "' (circle, sphere, torus, hollow)"));
  }
  return WriteObj(out, mesh);
}

}  // namespace meshgauge::cli
