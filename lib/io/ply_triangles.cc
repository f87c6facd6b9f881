// ReadTriangleBody (ply_body.h): a binary triangle mesh's vertices and
// faces decoded at fixed strides, a loop per element with the types fixed
// at compile time, instead of a call per value through the general
// reader's type switch, row and builder (6-8 times the time on a million
// vertices; docs/benchmarks.md).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lib/io/mesh_builder.h"
#include "lib/io/ply_body.h"

namespace meshgauge::io::ply {
namespace {

// Records decoded between two polls of the limits' cancellation.
constexpr int64_t kPollEvery = int64_t{1} << 18;

// Where a vertex's coordinates and a face's list sit in their records.
struct Layout {
  int64_t vertices = 0, faces = 0;
  size_t vertex_stride = 0;
  size_t xyz[3] = {0, 0, 0};  // byte offsets in a vertex record.
  Type coordinate = Type::kFloat32;
  // The vertex's other float and double properties (normals, a repeated
  // x): ReadBody refuses them too when they are not finite.
  std::vector<size_t> other_floats, other_doubles;
  Type count = Type::kUint8;
  Type index = Type::kInt32;
  size_t face_stride = 0;
};

// The layout when `h` describes a body ReadTriangleBody reads.
std::optional<Layout> TriangleLayout(const Header& h, size_t data_size) {
  if (h.format != Format::kLittle || h.elements.size() != 2) return {};
  const Element& v = h.elements[0];
  const Element& f = h.elements[1];
  // (Indices are int32: CheckCounts already keeps the vertex count far
  // below that on any file that can be read.)
  if (v.name != "vertex" || f.name != "face" || f.count == 0 ||
      v.count > std::numeric_limits<int32_t>::max()) {
    return {};
  }
  Layout l;
  l.vertices = v.count;
  l.faces = f.count;
  int found = 0;
  Type types[3] = {};
  std::vector<std::pair<size_t, Type>> floating;  // offset, type
  for (const Property& p : v.properties) {
    if (p.list) return {};
    for (int c = 0; c < 3; ++c) {
      // A repeated name: the last one counts, as in ReadBody.
      if (p.name == std::string(1, static_cast<char>('x' + c))) {
        l.xyz[c] = l.vertex_stride;
        types[c] = p.type;
        found |= 1 << c;
      }
    }
    if (!IsInteger(p.type)) floating.push_back({l.vertex_stride, p.type});
    l.vertex_stride += SizeOf(p.type);
  }
  l.coordinate = types[0];
  if (found != 7 || types[1] != types[0] || types[2] != types[0] ||
      (types[0] != Type::kFloat32 && types[0] != Type::kFloat64)) {
    return {};
  }
  for (const auto& [offset, type] : floating) {
    if (offset == l.xyz[0] || offset == l.xyz[1] || offset == l.xyz[2]) {
      continue;
    }
    (type == Type::kFloat32 ? l.other_floats : l.other_doubles)
        .push_back(offset);
  }
  if (f.properties.size() != 1) return {};
  const Property& list = f.properties[0];
  if (!list.list ||
      (list.name != "vertex_indices" && list.name != "vertex_index") ||
      (list.type != Type::kInt32 && list.type != Type::kUint32)) {
    return {};
  }
  l.count = list.count_type;
  l.index = list.type;
  l.face_stride = SizeOf(list.count_type) + 3 * SizeOf(list.type);
  // The body holds exactly the records (by division: no product of a
  // declared count can overflow).
  const size_t body = data_size - h.body;
  if (static_cast<uint64_t>(l.vertices) > body / l.vertex_stride) return {};
  const size_t face_bytes = body - l.vertices * l.vertex_stride;
  if (face_bytes % l.face_stride != 0 ||
      face_bytes / l.face_stride != static_cast<uint64_t>(l.faces)) {
    return {};
  }
  return l;
}

template <typename T>
T Load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// Vertices [begin, end) appended to `out`; false at a float or double
// that is not finite.
template <typename Coordinate>
bool DecodeVertices(const char* records, const Layout& l, int64_t begin,
                    int64_t end, std::vector<Vec3>& out) {
  for (int64_t i = begin; i < end; ++i) {
    const char* r = records + i * l.vertex_stride;
    const double x = Load<Coordinate>(r + l.xyz[0]);
    const double y = Load<Coordinate>(r + l.xyz[1]);
    const double z = Load<Coordinate>(r + l.xyz[2]);
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
      return false;
    }
    for (size_t o : l.other_floats) {
      if (!std::isfinite(Load<float>(r + o))) return false;
    }
    for (size_t o : l.other_doubles) {
      if (!std::isfinite(Load<double>(r + o))) return false;
    }
    out.push_back({x, y, z});
  }
  return true;
}

// Faces [begin, end) appended to `out`; false at a face that is not a
// triangle of vertices in range.
template <typename Count, typename Index>
bool DecodeFaces(const char* records, const Layout& l, int64_t begin,
                 int64_t end, std::vector<Face>& out) {
  constexpr size_t kItemsOffset = sizeof(Count);
  for (int64_t i = begin; i < end; ++i) {
    const char* r = records + i * l.face_stride;
    if (Load<Count>(r) != 3) return false;
    int64_t c[3];
    for (int k = 0; k < 3; ++k) {
      c[k] = static_cast<int64_t>(
          Load<Index>(r + kItemsOffset + k * sizeof(Index)));
    }
    if (c[0] < 0 || c[1] < 0 || c[2] < 0 || c[0] >= l.vertices ||
        c[1] >= l.vertices || c[2] >= l.vertices) {
      return false;
    }
    out.push_back(Face::Triangle(static_cast<int32_t>(c[0]),
                                 static_cast<int32_t>(c[1]),
                                 static_cast<int32_t>(c[2])));
  }
  return true;
}

template <typename Index>
bool DecodeFacesCounted(const char* records, const Layout& l, int64_t begin,
                        int64_t end, std::vector<Face>& out) {
  switch (l.count) {
    case Type::kInt8:
      return DecodeFaces<int8_t, Index>(records, l, begin, end, out);
    case Type::kUint8:
      return DecodeFaces<uint8_t, Index>(records, l, begin, end, out);
    case Type::kInt16:
      return DecodeFaces<int16_t, Index>(records, l, begin, end, out);
    case Type::kUint16:
      return DecodeFaces<uint16_t, Index>(records, l, begin, end, out);
    case Type::kInt32:
      return DecodeFaces<int32_t, Index>(records, l, begin, end, out);
    case Type::kUint32:
      return DecodeFaces<uint32_t, Index>(records, l, begin, end, out);
    case Type::kFloat32:
    case Type::kFloat64:
      break;  // not a count type (ParseHeader refuses it).
  }
  return false;
}

// One element's `records`: the limits' checks of `vertices` and `faces`
// and their reservation of `bytes`, then room() (the mesh's array
// reserved), then decode(begin, end) over blocks of kPollEvery records,
// cancellation polled between blocks. nullopt when decode fails, else the
// limits' status.
template <typename Room, typename Decode>
std::optional<absl::Status> ReadElement(const ReadLimits& limits,
                                        const std::string& path,
                                        int64_t vertices, int64_t faces,
                                        int64_t bytes, int64_t records,
                                        Room room, Decode decode) {
  if (absl::Status s = CheckReadCounts(&limits, path, vertices, faces);
      !s.ok()) {
    return s;
  }
  if (limits.reserve) {
    if (absl::Status s = limits.reserve(bytes); !s.ok()) return s;
  }
  room();
  for (int64_t begin = 0; begin < records; begin += kPollEvery) {
    // (CheckReadCounts polled before the first block.)
    if (begin > 0) {
      if (absl::Status s = CheckReadCancelled(&limits, path); !s.ok()) {
        return s;
      }
    }
    if (!decode(begin, std::min(records, begin + kPollEvery))) return {};
  }
  return absl::OkStatus();
}

}  // namespace

std::optional<absl::StatusOr<MeshFile>> ReadTriangleBody(
    absl::string_view data, const Header& h, const std::string& path,
    const ReadLimits& limits) {
  const std::optional<Layout> layout = TriangleLayout(h, data.size());
  if (!layout) return {};
  const Layout& l = *layout;
  const char* vertex_records = data.data() + h.body;
  const char* face_records = vertex_records + l.vertices * l.vertex_stride;
  MeshFile file;
  Mesh& mesh = file.mesh;
  const auto vertex_bytes = l.vertices * static_cast<int64_t>(sizeof(Vec3));
  const auto vertices = ReadElement(
      limits, path, l.vertices, 0, vertex_bytes, l.vertices,
      [&] { mesh.positions.reserve(l.vertices); },
      [&](int64_t begin, int64_t end) {
        return l.coordinate == Type::kFloat32
                   ? DecodeVertices<float>(vertex_records, l, begin, end,
                                           mesh.positions)
                   : DecodeVertices<double>(vertex_records, l, begin, end,
                                            mesh.positions);
      });
  if (!vertices) return {};
  if (!vertices->ok()) return *vertices;
  const auto faces = ReadElement(
      limits, path, l.vertices, l.faces,
      vertex_bytes + l.faces * static_cast<int64_t>(sizeof(Face)), l.faces,
      [&] { mesh.faces.reserve(l.faces); },
      [&](int64_t begin, int64_t end) {
        return l.index == Type::kInt32
                   ? DecodeFacesCounted<int32_t>(face_records, l, begin, end,
                                                 mesh.faces)
                   : DecodeFacesCounted<uint32_t>(face_records, l, begin, end,
                                                  mesh.faces);
      });
  if (!faces) return {};
  if (!faces->ok()) return *faces;
  file.format = FormatName(h.format);
  file.file_faces = l.faces;
  return file;
}

}  // namespace meshgauge::io::ply
