// meshgauge remote VERB ...: the CLI as a client of meshgauge-server.
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "client/cli/csv_io.h"
#include "client/remote/remote_client.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::cli {
namespace {

nlohmann::json InfoJson(const v1::SessionInfo& s) {
  return {{"session_id", s.session_id()},
          {"dimension", s.dimension()},
          {"vertices", s.num_vertices()},
          {"faces", s.num_faces()},
          {"generation", s.generation()},
          {"memory_bytes", s.memory_bytes()},
          {"bvh_builds", s.bvh_builds()},
          {"bvh_refits", s.bvh_refits()},
          {"idle_seconds", s.idle_seconds()},
          {"signed_volume", s.signed_volume()},
          {"closed", s.closed()},
          {"warnings",
           std::vector<std::string>(s.warnings().begin(), s.warnings().end())}};
}

void Print(const nlohmann::json& j, bool json) {
  if (json) {
    std::cout << j.dump() << "\n";
    return;
  }
  for (const auto& [k, v] : j.items()) std::cout << k << ": " << v << "\n";
}

absl::Status Upload(client::RemoteClient& c, const RemoteInput& in) {
  auto loaded = LoadMesh(in.target, in.in.mesh_flags);
  if (!loaded.ok()) return loaded.status();
  for (const auto& w : loaded->warnings)
    std::cerr << "meshgauge: warning: " << w << "\n";
  auto info = c.Upload(loaded->mesh, in.session_id);
  if (!info.ok()) return info.status();
  Print(InfoJson(*info), in.in.out.json);
  return absl::OkStatus();
}

absl::Status Sdf(client::RemoteClient& c, const RemoteInput& in) {
  const std::string& id = in.target;
  auto params = ToSdfParams(in.in.sdf);
  if (!params.ok()) return params.status();
  auto r = c.ComputeSdf(id, client::ToWireParams(*params));
  if (!r.ok()) return r.status();
  if (const std::string& csv = in.in.out.csv; !csv.empty()) {
    std::ofstream out(csv);
    out << "vertex,sdf,normalized,hits,kept,status\n";
    for (size_t i = 0; i < r->values.size(); ++i) {
      const bool ok = r->status[i] == v1::VERTEX_STATUS_OK;
      out << i << ",";
      if (ok)
        out << absl::StrFormat("%.17g,%.17g", r->values[i], r->normalized[i]);
      else
        out << ",";
      out << "," << r->hits[i] << "," << r->kept[i] << ","
          << v1::VertexStatus_Name(r->status[i])
                 .substr(strlen("VERTEX_STATUS_"))
          << "\n";
    }
    if (!out)
      return absl::InternalError(absl::StrCat("cannot write '", csv, "'"));
  }
  const v1::SdfSummary& s = r->summary;
  Print({{"generation", s.generation()},
         {"ok", s.ok()},
         {"no_hit", s.no_hit()},
         {"no_faces", s.no_faces()},
         {"sdf_min", s.sdf_min()},
         {"sdf_max", s.sdf_max()},
         {"sdf_mean", s.sdf_mean()},
         {"integral", s.integral()},
         {"rays", s.rays()},
         {"seconds", s.seconds()},
         {"reused_hits", s.reused_hits()}},
        in.in.out.json);
  return absl::OkStatus();
}

absl::Status Grad(client::RemoteClient& c, const RemoteInput& in) {
  const std::string& id = in.target;
  auto params = ToSdfParams(in.in.sdf);
  if (!params.ok()) return params.status();
  auto info = c.Get(id);
  if (!info.ok()) return info.status();
  auto w = ReadWeights(in.grad.weights, info->num_vertices());
  if (!w.ok()) return w.status();
  auto r = c.ComputeVjp(id, client::ToWireParams(*params), *w);
  if (!r.ok()) return r.status();
  const auto grad = client::FromFlattened(r->gradient(), info->dimension());
  if (const std::string& path = in.grad.vjp; !path.empty()) {
    if (absl::Status s = WriteVectorCsv(path, grad); !s.ok()) return s;
  }
  Print({{"generation", r->generation()},
         {"vjp_max_norm", MaxNorm(grad)},
         {"reused_hits", r->reused_hits()},
         {"seconds", r->seconds()}},
        in.in.out.json);
  return absl::OkStatus();
}

absl::Status Penalty(client::RemoteClient& c, const RemoteInput& in) {
  const std::string& id = in.target;
  auto params = ToSdfParams(in.in.sdf);
  if (!params.ok()) return params.status();
  auto penalty = ToPenaltyParams(in.penalty);
  if (!penalty.ok()) return penalty.status();
  const std::string& grad_path = in.penalty.grad;
  auto info = c.Get(id);
  if (!info.ok()) return info.status();
  auto r = c.ComputePenalty(id, client::ToWireParams(*params), *penalty,
                            !grad_path.empty());
  if (!r.ok()) return r.status();
  if (!grad_path.empty()) {
    if (absl::Status s = WriteVectorCsv(
            grad_path, client::FromFlattened(r->gradient(), info->dimension()));
        !s.ok()) {
      return s;
    }
  }
  Print({{"generation", r->generation()},
         {penalty->form == PenaltyForm::kKs ? "constraint" : "penalty",
          r->value()},
         {"form", PenaltyFormName(penalty->form)},
         {"skipped_faces", r->missing().faces()},
         {"missing_vertices", r->missing().vertices()},
         {"missing_area_fraction", r->missing().area_fraction()},
         {"world_frame_vertices", r->world_frame_vertices()},
         {"sdf_min", r->sdf_min()},
         {"reused_hits", r->reused_hits()}},
        in.in.out.json);
  return absl::OkStatus();
}

absl::Status Calibrate(client::RemoteClient& c, const RemoteInput& in) {
  auto params = ToSdfParams(in.in.sdf);
  if (!params.ok()) return params.status();
  auto r = c.Calibrate(in.target, client::ToWireParams(*params),
                       in.calibrate.t_min, in.calibrate.tolerance,
                       in.calibrate.bins);
  if (!r.ok()) return r.status();
  Print({{"compared", r->compared()},
         {"sdf_lower", r->sdf_lower()},
         {"sdf_equal", r->sdf_equal()},
         {"sdf_higher", r->sdf_higher()},
         {"equal_tolerance", in.calibrate.tolerance},
         {"t_min", in.calibrate.t_min},
         {"alpha1", r->alpha1()},
         {"alpha2", r->alpha2()},
         {"histogram_range", {r->histogram_lo(), r->histogram_hi()}},
         {"sdf_histogram", std::vector<int64_t>(r->sdf_histogram().begin(),
                                                r->sdf_histogram().end())},
         {"thickness_histogram",
          std::vector<int64_t>(r->thickness_histogram().begin(),
                               r->thickness_histogram().end())}},
        in.in.out.json);
  return absl::OkStatus();
}

absl::Status Update(client::RemoteClient& c, const RemoteInput& in) {
  const std::string& id = in.target;
  auto mesh = ReadMesh(in.positions);
  if (!mesh.ok()) return mesh.status();
  auto info = c.Get(id);
  if (!info.ok()) return info.status();
  int64_t gen = in.generation;
  if (gen < 0) gen = info->generation();
  auto r = c.UpdatePositions(id, gen, info->dimension(), mesh->positions);
  if (!r.ok()) return r.status();
  Print({{"generation", r->generation()},
         {"refit", r->refit()},
         {"bvh_seconds", r->bvh_seconds()}},
        in.in.out.json);
  return absl::OkStatus();
}

}  // namespace

absl::Status RunRemote(const RemoteInput& in) {
  client::ClientOptions options;
  if (absl::Status s = client::LoadClientSecrets(
          in.remote.tls_ca_file, in.remote.tls_cert_file,
          in.remote.tls_key_file, in.remote.token_file, &options);
      !s.ok()) {
    return s;
  }
  if (options.tls_ca_pem.empty() &&
      !(options.tls_cert_pem.empty() && options.tls_key_pem.empty())) {
    return absl::InvalidArgumentError(
        "--tls-cert-file/--tls-key-file need --tls-ca-file");
  }
  client::RemoteClient c(in.remote.server, options);
  const std::string& verb = in.verb;
  const bool json = in.in.out.json;
  if (verb == "upload") return Upload(c, in);
  if (verb == "health") {
    // Exit status 0 only when SERVING (container health checks).
    auto serving = c.Serving();
    if (!serving.ok()) return serving.status();
    if (!*serving) return absl::UnavailableError("NOT_SERVING (draining)");
    std::cout << "SERVING\n";
    return absl::OkStatus();
  }
  if (verb == "list") {
    auto all = c.List();
    if (!all.ok()) return all.status();
    nlohmann::json j = nlohmann::json::array();
    for (const auto& s : *all) j.push_back(InfoJson(s));
    if (json) {
      std::cout << j.dump() << "\n";
    } else {
      for (const auto& s : *all) {
        std::cout << absl::StrFormat("%-24s %dD %10d vertices  generation %d\n",
                                     s.session_id(), s.dimension(),
                                     s.num_vertices(), s.generation());
      }
    }
    return absl::OkStatus();
  }
  if (verb == "info") {
    auto info = c.Get(in.target);
    if (!info.ok()) return info.status();
    Print(InfoJson(*info), json);
    return absl::OkStatus();
  }
  if (verb == "delete") return c.Delete(in.target);
  if (verb == "sdf") return Sdf(c, in);
  if (verb == "grad") return Grad(c, in);
  if (verb == "penalty") return Penalty(c, in);
  if (verb == "calibrate") return Calibrate(c, in);
  if (verb == "update") return Update(c, in);
  return absl::InvalidArgumentError(
      absl::StrCat("unknown remote verb '", verb, "'"));
}

}  // namespace meshgauge::cli
