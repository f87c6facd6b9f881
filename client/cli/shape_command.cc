#include <cmath>
#include <fstream>
#include <numbers>

#include "absl/flags/flag.h"
#include "absl/strings/str_cat.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::cli {

absl::Status RunShape(const std::vector<std::string>& args) {
  const std::string out = absl::GetFlag(FLAGS_out);
  const double h = absl::GetFlag(FLAGS_size);
  const double r = absl::GetFlag(FLAGS_radius);
  if (args.size() != 1 || out.empty()) {
    return absl::InvalidArgumentError(
        "usage: meshgauge shape circle|sphere|torus|hollow --out FILE "
        "[--size H] [--radius R]");
  }
  if (!(h > 0) || !(r > 0) || h > r) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--size and --radius must be > 0 with size <= radius, got ", h, ", ",
        r));
  }
  Mesh mesh;
  if (args[0] == "circle") {
    mesh = MakeCircle(
        r, static_cast<int>(std::ceil(2 * std::numbers::pi * r / h)));
  } else if (args[0] == "sphere") {
    mesh = MakeIcosphere(r, static_cast<int>(std::ceil(1.0515 * r / h)));
  } else if (args[0] == "torus") {
    mesh = MakeTorus(2 * r, r,
                     static_cast<int>(std::ceil(4 * std::numbers::pi * r / h)),
                     static_cast<int>(std::ceil(2 * std::numbers::pi * r / h)));
  } else if (args[0] == "hollow") {
    mesh = MakeHollowSquare(4 * r, r, h);
  } else {
    return absl::InvalidArgumentError(absl::StrCat(
        "unknown shape '", args[0], "' (circle, sphere, torus, hollow)"));
  }
  return WriteObj(out, mesh);
}

}  // namespace meshgauge::cli
