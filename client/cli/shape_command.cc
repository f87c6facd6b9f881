#include <cmath>
#include <fstream>
#include <numbers>

#include "absl/flags/flag.h"
#include "absl/strings/str_cat.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "lib/shapes.h"

namespace meshgauge::cli {
namespace {

absl::Status WriteObj(const std::string& path, const Mesh& mesh) {
  std::ofstream out(path);
  if (!out)
    return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
  out.precision(17);
  for (const Vec3& p : mesh.positions) {
    out << "v " << p.x << " " << p.y << " " << p.z << "\n";
  }
  int32_t region = 0;
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    if (mesh.RegionOf(f) != region || f == 0) {
      region = mesh.RegionOf(f);
      out << "g " << region << "\n";
    }
    const Face& face = mesh.faces[f];
    out << (face.size == 2 ? "l" : "f");
    for (int k = 0; k < face.size; ++k) out << " " << face.v[k] + 1;
    out << "\n";
  }
  if (!out)
    return absl::InternalError(absl::StrCat("error writing '", path, "'"));
  return absl::OkStatus();
}

}  // namespace

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
