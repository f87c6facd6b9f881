#include "client/cli/csv_io.h"

#include <cmath>
#include <fstream>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/strip.h"

namespace meshgauge::cli {

absl::Status WriteVectorCsv(const std::string& path,
                            const std::vector<Vec3>& v) {
  std::ofstream out(path);
  if (!out)
    return absl::InternalError(absl::StrCat("cannot write '", path, "'"));
  out << "vertex,dx,dy,dz\n";
  for (size_t i = 0; i < v.size(); ++i) {
    out << absl::StrFormat("%d,%.17g,%.17g,%.17g\n", i, v[i].x, v[i].y, v[i].z);
  }
  if (!out)
    return absl::InternalError(absl::StrCat("error writing '", path, "'"));
  return absl::OkStatus();
}

absl::StatusOr<std::vector<double>> ReadWeights(const std::string& path,
                                                int64_t nv,
                                                absl::string_view samples) {
  if (path.empty()) return std::vector<double>(nv, 1.0);
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open '", path, "'"));
  std::vector<double> w;
  std::string line;
  int64_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const absl::string_view s = absl::StripAsciiWhitespace(line);
    if (s.empty()) continue;
    double x = 0;
    if (!absl::SimpleAtod(s, &x) || !std::isfinite(x)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "'", path, "' line ", line_no, ": not a finite number: '", s, "'"));
    }
    w.push_back(x);
  }
  if (std::ssize(w) != nv) {
    return absl::InvalidArgumentError(
        absl::StrCat("'", path, "' has ", w.size(),
                     " weights but the mesh has ", nv, " ", samples));
  }
  return w;
}

double MaxNorm(const std::vector<Vec3>& v) {
  double m = 0;
  for (const Vec3& x : v) m = std::max(m, Norm(x));
  return m;
}

}  // namespace meshgauge::cli
