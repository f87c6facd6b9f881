// The body readers behind ParsePly (lib/io/readers.h), on a file's
// contents and its parsed header (ParseHeader, CheckCounts passed).
#pragma once

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "lib/io/mesh_file.h"
#include "lib/io/ply_header.h"

namespace meshgauge::io::ply {

// Any body: ASCII or binary of either byte order, every element and
// property honoured (ParsePly's contract). Errors: InvalidArgument naming
// the line or byte; the limits'.
absl::StatusOr<MeshFile> ReadBody(absl::string_view data, const Header& h,
                                  const std::string& path,
                                  const ReadLimits& limits);

// The common binary triangle mesh, read without a call per value: a
// little-endian body of exactly two elements, `vertex` (scalar properties
// only; x, y, z all float or all double) then `face` (one property, the
// list vertex_indices or vertex_index of int or uint items), every face a
// triangle, no byte after the faces. The same MeshFile as ReadBody, bit
// for bit. nullopt when the file has another layout, or holds a value
// ReadBody rejects (a coordinate that is not finite, an index out of range,
// a face that is not a triangle): ReadBody then reads it and names the
// place. Errors: the limits' (checked, as ReadBody does, before the
// vertices and before the faces are stored). Its reservations are the bytes
// it stores (the positions, then the positions and the faces), less than
// ReadBody's, which leave its arrays room to double: under a tight budget
// a file it takes may pass where the same mesh in another layout does not.
std::optional<absl::StatusOr<MeshFile>> ReadTriangleBody(
    absl::string_view data, const Header& h, const std::string& path,
    const ReadLimits& limits);

}  // namespace meshgauge::io::ply
