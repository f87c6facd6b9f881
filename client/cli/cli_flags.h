// The meshgauge CLI's flags: one options struct per concern, registered on
// each subcommand that takes them (CLI11, dashed long names), and their
// conversion to library types. This file is the only place flags are
// defined; commands receive the filled structs.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/cli/progress_bar.h"
#include "lib/core/components.h"
#include "lib/core/mesh.h"
#include "lib/core/penalty.h"
#include "lib/core/sdf_types.h"
#include "lib/core/weld.h"

namespace meshgauge::cli {

// --method --cone-angle --contact-angle --rays --kappa --threads
// --max-distance --normals --opposite (and, on the verbs that take it,
// --samples vertices|faces).
struct SdfFlags {
  std::string method = "cone";
  double cone_angle = 30;
  double contact_angle = 60;
  bool opposite = false;
  int rays = 0;  // 0: not given (100 in 3D, 32 in 2D).
  double kappa = 1.0;
  int threads = 0;
  double max_distance = 0;
  std::string normals = "area";
  std::string samples = "vertices";  // vertices or faces (SPEC v2 §5c).
};

// --region-direction --reorient --drop-degenerate-faces.
struct MeshFlags {
  std::vector<std::string> region_directions;
  bool reorient = false;
  bool drop_degenerate_faces = false;
  bool weld = false;          // --weld [TOL]
  double weld_tolerance = 0;  // relative to the bounding box's diagonal.
};

// --csv --ply --opposite-ply --json --warn-missing-fraction.
struct OutputFlags {
  std::string csv, ply, opposite_ply;
  bool json = false;
  double warn_missing_fraction = 0.01;
  std::string progress = "auto";  // auto, always or never
  ProgressMode Progress() const {
    return progress == "always"  ? ProgressMode::kAlways
           : progress == "never" ? ProgressMode::kNever
                                 : ProgressMode::kAuto;
  }
};

// --t-min --form --power --rho --max-missing-fraction --grad.
struct PenaltyFlags {
  double t_min = 0;
  std::string form = "one-sided";
  double power = 2;
  double rho = 50;
  double max_missing_fraction = 0.5;
  std::string grad;
};

// --weights --vjp --jacobian --max-missing-fraction.
struct GradFlags {
  std::string weights, vjp, jacobian;
  double max_missing_fraction = 0.5;
};

// --t-min --tolerance --bins.
struct CalibrateFlags {
  double t_min = 0;
  double tolerance = 0.01;
  int bins = 20;
};

// --probes --seed --fd-tolerance (and the penalty's with --t-min); its
// --samples is SdfFlags' (vertices|faces) or, as before --probes existed, a
// count of probed vertices.
struct GradcheckFlags {
  int probes = 0;   // --probes; 0: not given (12).
  int counted = 0;  // --samples N; 0: not given.
  // The vertices to probe: --probes or --samples N (not both), else 12.
  absl::StatusOr<int> Probes() const {
    if (probes > 0 && counted > 0) {
      return absl::InvalidArgumentError(
          "give --probes N or --samples N (its older spelling), not both");
    }
    return probes > 0 ? probes : counted > 0 ? counted : 12;
  }
  uint64_t seed = 1;
  double fd_tolerance = 1e-5;
};

// --t-min --min-region-area --out --view-size --up --bins --color-range.
struct ReportFlags {
  double t_min = 0;
  double min_region_area = 0;
  std::string out;
  std::vector<int> view_size = {500, 400};
  std::string up = "z";
  int bins = 40;
  std::vector<double> color_range;  // empty: [0, 2 t_min].
  double max_missing_fraction = 0.5;
};

// --server --tls-ca-file --tls-cert-file --tls-key-file --token-file.
struct RemoteFlags {
  std::string server = "127.0.0.1:50051";
  std::string tls_ca_file, tls_cert_file, tls_key_file, token_file;
  // Seconds a call waits for a connection before it fails UNAVAILABLE; 0:
  // the client's default (client::ClientOptions).
  double connect_timeout = 0;
};

// Validators of numbers > 0 and >= 0 (out of range: a usage error).
CLI::Validator Positive();
CLI::Validator NonNegative();

// --threads into *threads, 0..1024 (0: all cores); `help` says what they
// run.
void AddThreadsFlag(CLI::App* app, int* threads, const std::string& help);
void AddSdfFlags(CLI::App* app, SdfFlags* f);
// --samples vertices|faces: where the values are (SPEC v2 §5c).
void AddSamplesFlag(CLI::App* app, SdfFlags* f);
void AddMeshFlags(CLI::App* app, MeshFlags* f);
void AddOutputFlags(CLI::App* app, OutputFlags* f, bool files);
// t_min_required: --t-min is required (penalty) or optional (gradcheck).
void AddPenaltyFlags(CLI::App* app, PenaltyFlags* f, bool t_min_required);
void AddGradFlags(CLI::App* app, GradFlags* f);
void AddCalibrateFlags(CLI::App* app, CalibrateFlags* f);
void AddGradcheckFlags(CLI::App* app, GradcheckFlags* f, SdfFlags* sdf);
// In meshgauge_cli_remote_lib (remote_commands.cc): the local CLI links no
// gRPC.
void AddRemoteFlags(CLI::App* app, RemoteFlags* f);
void AddReportFlags(CLI::App* app, ReportFlags* f);

// SdfParams, validated. Errors: InvalidArgument naming the flag.
absl::StatusOr<SdfParams> ToSdfParams(const SdfFlags& f);
// PenaltyParams, validated. Errors: InvalidArgument naming the flag.
absl::StatusOr<PenaltyParams> ToPenaltyParams(const PenaltyFlags& f);

// A mesh read from a file with --region-direction, --drop-degenerate-faces
// and --reorient applied.
struct LoadedMesh {
  Mesh mesh;
  std::string format;
  int64_t polygons_triangulated = 0;
  int64_t polygons_fallback = 0;  // of those, not simple (fallback).
  Weld weld;  // --weld: the input's vertices in the mesh's.
  int64_t dropped_faces = 0;
  double signed_volume = 0;
  bool closed = false;
  int64_t reoriented = 0;             // closed components turned outward.
  int64_t faces_made_consistent = 0;  // reversed to agree (--reorient).
  MeshDiagnostics diagnostics;        // after the fixes.
  std::vector<std::string> warnings;
  double read_seconds = 0;   // parsing the file
  double check_seconds = 0;  // repairs, validation and diagnostics
};

// Reads and validates `path`; inward-oriented closed components, double-
// sided faces and open meshes are reported in `warnings`; the inward
// components are reversed only with --reorient. The checks use at most
// `threads` threads (0: all cores).
absl::StatusOr<LoadedMesh> LoadMesh(const std::string& path,
                                    const MeshFlags& flags, int threads);

}  // namespace meshgauge::cli
