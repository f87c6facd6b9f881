// meshgauge remote VERB ...: the CLI as a client of meshgauge-server.
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "absl/flags/flag.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "client/cli/csv_io.h"
#include "client/remote/remote_client.h"
#include "lib/io/mesh_io.h"

ABSL_FLAG(std::string, server, "127.0.0.1:50051",
          "meshgauge remote: server address host:port");
ABSL_FLAG(std::string, session_id, "",
          "meshgauge remote upload: session id (default: server-assigned)");
ABSL_FLAG(std::string, positions, "",
          "meshgauge remote update: mesh file with the new positions (same "
          "vertex count)");
ABSL_FLAG(int64_t, generation, -1,
          "meshgauge remote update: expected generation (-1: the current)");
ABSL_FLAG(std::string, tls_ca_file, "",
          "meshgauge remote: connect with TLS, trusting this PEM CA");
ABSL_FLAG(std::string, tls_cert_file, "",
          "meshgauge remote: client certificate (PEM) for mutual TLS");
ABSL_FLAG(std::string, tls_key_file, "",
          "meshgauge remote: private key (PEM) of --tls-cert-file");
ABSL_FLAG(std::string, token_file, "",
          "meshgauge remote: file whose first line is the bearer token "
          "(default: the MESHGAUGE_TOKEN environment variable)");

namespace meshgauge::cli {
namespace {

constexpr char kUsage[] =
    "usage: meshgauge remote upload MESH [--session-id ID] | list | health | "
    "info ID | "
    "delete ID | sdf ID [--csv FILE] | grad ID [--weights FILE] [--vjp FILE] | "
    "penalty ID --t-min T [--phi ...] [--power n] [--grad FILE] | update ID "
    "--positions MESH [--generation G]   (all take --server host:port)";

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

void Print(const nlohmann::json& j) {
  if (absl::GetFlag(FLAGS_json)) {
    std::cout << j.dump() << "\n";
    return;
  }
  for (const auto& [k, v] : j.items()) std::cout << k << ": " << v << "\n";
}

absl::Status NeedArgs(const std::vector<std::string>& args, size_t n) {
  return args.size() == n ? absl::OkStatus()
                          : absl::InvalidArgumentError(kUsage);
}

absl::Status Upload(client::RemoteClient& c,
                    const std::vector<std::string>& a) {
  if (absl::Status s = NeedArgs(a, 2); !s.ok()) return s;
  auto loaded = LoadMeshFromFlags(a[1]);
  if (!loaded.ok()) return loaded.status();
  for (const auto& w : loaded->warnings)
    std::cerr << "meshgauge: warning: " << w << "\n";
  auto info = c.Upload(loaded->mesh, absl::GetFlag(FLAGS_session_id));
  if (!info.ok()) return info.status();
  Print(InfoJson(*info));
  return absl::OkStatus();
}

absl::Status Sdf(client::RemoteClient& c, const std::string& id) {
  auto params = SdfParamsFromFlags();
  if (!params.ok()) return params.status();
  auto r = c.ComputeSdf(id, client::ToWireParams(*params));
  if (!r.ok()) return r.status();
  if (const std::string csv = absl::GetFlag(FLAGS_csv); !csv.empty()) {
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
         {"reused_hits", s.reused_hits()}});
  return absl::OkStatus();
}

absl::Status Grad(client::RemoteClient& c, const std::string& id) {
  auto params = SdfParamsFromFlags();
  if (!params.ok()) return params.status();
  auto info = c.Get(id);
  if (!info.ok()) return info.status();
  auto w = ReadWeights(absl::GetFlag(FLAGS_weights), info->num_vertices());
  if (!w.ok()) return w.status();
  auto r = c.ComputeVjp(id, client::ToWireParams(*params), *w);
  if (!r.ok()) return r.status();
  const auto grad = client::FromFlattened(r->gradient(), info->dimension());
  if (const std::string path = absl::GetFlag(FLAGS_vjp); !path.empty()) {
    if (absl::Status s = WriteVectorCsv(path, grad); !s.ok()) return s;
  }
  Print({{"generation", r->generation()},
         {"vjp_max_norm", MaxNorm(grad)},
         {"reused_hits", r->reused_hits()},
         {"seconds", r->seconds()}});
  return absl::OkStatus();
}

absl::Status Penalty(client::RemoteClient& c, const std::string& id) {
  auto params = SdfParamsFromFlags();
  if (!params.ok()) return params.status();
  auto penalty = PenaltyParamsFromFlags();
  if (!penalty.ok()) return penalty.status();
  const std::string grad_path = absl::GetFlag(FLAGS_grad);
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
         {"reused_hits", r->reused_hits()}});
  return absl::OkStatus();
}

absl::Status Update(client::RemoteClient& c, const std::string& id) {
  const std::string path = absl::GetFlag(FLAGS_positions);
  if (path.empty())
    return absl::InvalidArgumentError("--positions MESH is required");
  auto mesh = ReadMesh(path);
  if (!mesh.ok()) return mesh.status();
  auto info = c.Get(id);
  if (!info.ok()) return info.status();
  int64_t gen = absl::GetFlag(FLAGS_generation);
  if (gen < 0) gen = info->generation();
  auto r = c.UpdatePositions(id, gen, info->dimension(), mesh->positions);
  if (!r.ok()) return r.status();
  Print({{"generation", r->generation()},
         {"refit", r->refit()},
         {"bvh_seconds", r->bvh_seconds()}});
  return absl::OkStatus();
}

}  // namespace

absl::Status RunRemote(const std::vector<std::string>& args) {
  if (args.empty()) return absl::InvalidArgumentError(kUsage);
  client::ClientOptions options;
  if (absl::Status s = client::LoadClientSecrets(
          absl::GetFlag(FLAGS_tls_ca_file), absl::GetFlag(FLAGS_tls_cert_file),
          absl::GetFlag(FLAGS_tls_key_file), absl::GetFlag(FLAGS_token_file),
          &options);
      !s.ok()) {
    return s;
  }
  if (options.tls_ca_pem.empty() &&
      !(options.tls_cert_pem.empty() && options.tls_key_pem.empty())) {
    return absl::InvalidArgumentError(
        "--tls-cert-file/--tls-key-file need --tls-ca-file");
  }
  client::RemoteClient c(absl::GetFlag(FLAGS_server), options);
  const std::string& verb = args[0];
  if (verb == "upload") return Upload(c, args);
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
    if (absl::GetFlag(FLAGS_json)) {
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
  if (absl::Status s = NeedArgs(args, 2); !s.ok()) return s;
  const std::string& id = args[1];
  if (verb == "info") {
    auto info = c.Get(id);
    if (!info.ok()) return info.status();
    Print(InfoJson(*info));
    return absl::OkStatus();
  }
  if (verb == "delete") return c.Delete(id);
  if (verb == "sdf") return Sdf(c, id);
  if (verb == "grad") return Grad(c, id);
  if (verb == "penalty") return Penalty(c, id);
  if (verb == "update") return Update(c, id);
  return absl::InvalidArgumentError(
      absl::StrCat("unknown remote verb '", verb, "'\n", kUsage));
}

}  // namespace meshgauge::cli
