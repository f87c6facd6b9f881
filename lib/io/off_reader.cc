// ASCII OFF (and COFF, NOFF, CNOFF: extra numbers per vertex are parsed and
// ignored): a header, the counts "V F E", the vertices "x y z [colour]",
// then the faces "n i_1 ... i_n [colour]"; coordinates and indices may
// spread over lines (as libigl and others write long faces), a colour
// stands on the line that ends its vertex or face. Binary OFF is not
// supported.
#include <vector>

#include "absl/strings/str_cat.h"
#include "lib/io/mesh_builder.h"
#include "lib/io/readers.h"
#include "lib/io/scan.h"

namespace meshgauge::io {
namespace {

bool ReadCount(TokenScanner& scan, int64_t* out) {
  absl::string_view tok;
  return scan.Next(&tok) && ParseInt64(tok, out);
}

struct OffCounts {
  int64_t vertices = 0, faces = 0;
};

// The header and its counts "V F E" (on its line or on the next).
absl::StatusOr<OffCounts> ReadHeader(TokenScanner& scan,
                                     const std::string& path) {
  absl::string_view tok;
  if (!scan.Next(&tok) ||
      (tok != "OFF" && tok != "COFF" && tok != "NOFF" && tok != "CNOFF")) {
    return LineError(path, scan.line(), "not an OFF file (no OFF header)");
  }
  absl::string_view next;
  if (scan.NextOnLine(&next) && next == "BINARY") {
    return LineError(path, scan.line(),
                     "binary OFF is not supported; convert it to ASCII OFF, "
                     "PLY or STL");
  }
  OffCounts counts;
  int64_t edges = 0;
  const bool have_nv = !next.empty() && ParseInt64(next, &counts.vertices);
  if (!next.empty() && !have_nv) {
    return LineError(path, scan.line(),
                     absl::StrCat("unexpected ", Quote(next), " after OFF"));
  }
  if ((!have_nv && !ReadCount(scan, &counts.vertices)) ||
      !ReadCount(scan, &counts.faces) || !ReadCount(scan, &edges)) {
    return LineError(path, scan.line(),
                     "expected the counts 'vertices faces edges'");
  }
  return counts;
}

// Vertex v of nv: "x y z", then numbers only (a colour or a normal) up to
// the end of the line.
absl::Status ReadVertex(TokenScanner& scan, const std::string& path, int64_t v,
                        int64_t nv, MeshBuilder& builder) {
  absl::string_view tok;
  double xyz[3];
  for (int c = 0; c < 3; ++c) {
    if (!scan.Next(&tok)) {
      return LineError(
          path, scan.line(),
          absl::StrCat("vertex ", v, " of ", nv, ": expected 3 coordinates"));
    }
    if (!ParseDouble(tok, &xyz[c])) {
      return LineError(path, scan.line(),
                       absl::StrCat("vertex ", v, ": ", Quote(tok),
                                    " is not a finite number"));
    }
  }
  while (scan.NextOnLine(&tok)) {  // colour or normal: numbers only.
    double ignored;
    if (!ParseDouble(tok, &ignored)) {
      return LineError(path, scan.line(),
                       absl::StrCat("vertex ", v, ": unexpected ", Quote(tok)));
    }
  }
  return builder.AddVertex({xyz[0], xyz[1], xyz[2]});
}

// Face f of nf: "n i_1 ... i_n" (the indices may continue on the following
// lines), then an optional colour up to the end of the line.
absl::Status ReadFace(TokenScanner& scan, const std::string& path, int64_t f,
                      int64_t nf, std::vector<int64_t>& corners,
                      MeshBuilder& builder) {
  absl::string_view tok;
  int64_t n = 0;
  if (!scan.Next(&tok)) {
    return LineError(
        path, scan.line(),
        absl::StrCat("the file ends after ", f, " of ", nf, " declared faces"));
  }
  const int64_t line = scan.line();
  if (!ParseInt64(tok, &n) || n < 3) {
    return LineError(path, line,
                     absl::StrCat("face ", f, ": ", Quote(tok),
                                  " is not a corner count >= 3"));
  }
  corners.clear();
  for (int64_t k = 0; k < n; ++k) {
    int64_t index;
    if (!scan.Next(&tok) || !ParseInt64(tok, &index)) {
      return LineError(
          path, scan.line(),
          absl::StrCat("face ", f, ": expected ", n, " vertex indices"));
    }
    corners.push_back(index);
    if (k > kMaxCornersPerRecord) break;  // AddFace reports the excess.
  }
  while (scan.NextOnLine(&tok)) {  // an optional colour.
    double ignored;
    if (!ParseDouble(tok, &ignored)) {
      return LineError(path, line,
                       absl::StrCat("face ", f, ": unexpected ", Quote(tok)));
    }
  }
  return builder.AddFace(corners, 0, AtLine(line));
}

}  // namespace

absl::StatusOr<MeshFile> ParseOff(absl::string_view text,
                                  const std::string& path,
                                  const ReadLimits& limits) {
  if (absl::Status s = CheckLineEnds(path, text); !s.ok()) return s;
  TokenScanner scan(text, '#');
  auto counts = ReadHeader(scan, path);
  if (!counts.ok()) return counts.status();
  const int64_t nv = counts->vertices, nf = counts->faces;
  const size_t left = text.size() - scan.offset();
  // A vertex line holds at least "0 0 0\n" (6 bytes), a face "3 0 1 2\n".
  if (absl::Status s = CheckDeclaredCount(path, "vertices", nv, 6, left);
      !s.ok())
    return s;
  if (absl::Status s = CheckDeclaredCount(path, "faces", nf, 8, left - 6 * nv);
      !s.ok())
    return s;
  MeshBuilder builder(path, 3, &limits);
  if (absl::Status s = builder.ReservePositions(nv); !s.ok()) return s;
  if (absl::Status s = builder.ReserveFaces(nf, 3); !s.ok()) return s;
  for (int64_t v = 0; v < nv; ++v) {
    if (absl::Status s = ReadVertex(scan, path, v, nv, builder); !s.ok()) {
      return s;
    }
  }
  std::vector<int64_t> corners;
  for (int64_t f = 0; f < nf; ++f) {
    if (absl::Status s = ReadFace(scan, path, f, nf, corners, builder);
        !s.ok()) {
      return s;
    }
  }
  if (!scan.AtEnd()) {
    return LineError(
        path, scan.line(),
        absl::StrCat("unexpected data after the ", nf, " declared faces"));
  }
  return builder.Finish("off");
}

}  // namespace meshgauge::io
