// meshgauge remote upload|list|health|server-info|info|delete|update: the
// sessions of a meshgauge-server and its limits.
#include <iostream>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/cli/backend.h"
#include "client/cli/cli_flags.h"
#include "client/cli/commands.h"
#include "client/remote/remote_client.h"
#include "lib/io/mesh_io.h"

namespace meshgauge::cli {
namespace {

nlohmann::json InfoJson(const wire::SessionInfo& s) {
  return {{"session_id", s.session_id},
          {"dimension", s.dimension},
          {"vertices", s.num_vertices},
          {"faces", s.num_faces},
          {"generation", s.generation},
          {"memory_bytes", s.memory_bytes},
          {"bvh_builds", s.bvh_builds},
          {"bvh_refits", s.bvh_refits},
          {"idle_seconds", s.idle_seconds},
          {"signed_volume", s.signed_volume},
          {"closed", s.closed},
          {"warnings", s.warnings}};
}

nlohmann::json ServerJson(const wire::ServerInfo& s) {
  return {{"version", s.version},
          {"api", s.api},
          {"max_rays", s.max_rays},
          {"max_vertices", s.max_vertices},
          {"max_faces", s.max_faces},
          {"max_message_bytes", s.max_message_bytes},
          {"max_upload_message_bytes", s.max_upload_message_bytes},
          {"max_upload_file_bytes", s.max_upload_file_bytes},
          {"max_sessions", s.max_sessions},
          {"memory_budget_bytes", s.memory_budget_bytes}};
}

void Print(const nlohmann::json& j, bool json) {
  if (json) {
    std::cout << j.dump() << "\n";
    return;
  }
  for (const auto& [k, v] : j.items()) std::cout << k << ": " << v << "\n";
}

absl::Status Upload(client::RemoteClient& c, const RemoteInput& in) {
  auto loaded = LoadMesh(in.target, in.mesh_flags, in.threads);
  if (!loaded.ok()) return loaded.status();
  PrintWarnings(loaded->warnings);
  auto info = c.Upload(loaded->mesh, in.session_id);
  if (!info.ok()) return info.status();
  Print(InfoJson(*info), in.json);
  return absl::OkStatus();
}

absl::Status Update(client::RemoteClient& c, const RemoteInput& in) {
  const std::string& id = in.target;
  auto mesh = ReadMesh(in.positions);
  if (!mesh.ok()) return mesh.status();
  auto info = c.Get(id);
  if (!info.ok()) return info.status();
  int64_t gen = in.generation;
  if (gen < 0) gen = info->generation;
  auto r = c.UpdatePositions(id, gen, info->dimension, mesh->positions);
  if (!r.ok()) return r.status();
  Print({{"generation", r->generation},
         {"refit", r->refit},
         {"bvh_seconds", r->bvh_seconds}},
        in.json);
  return absl::OkStatus();
}

}  // namespace

absl::Status RunRemote(const RemoteInput& in) {
  auto connected = Connect(in.remote);
  if (!connected.ok()) return connected.status();
  client::RemoteClient& c = **connected;
  const std::string& verb = in.verb;
  const bool json = in.json;
  if (verb == "upload") return Upload(c, in);
  if (verb == "health") {
    // Exit status 0 only when SERVING (container health checks).
    auto serving = c.Serving();
    if (!serving.ok()) return serving.status();
    if (!*serving) return absl::UnavailableError("NOT_SERVING (draining)");
    std::cout << (json ? R"({"status":"SERVING"})" : "SERVING") << "\n";
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
        std::cout << absl::StrFormat("%-36s %dD %10d vertices  generation %d\n",
                                     s.session_id, s.dimension, s.num_vertices,
                                     s.generation);
      }
    }
    return absl::OkStatus();
  }
  if (verb == "server-info") {
    auto info = c.GetServerInfo();
    if (!info.ok()) return info.status();
    Print(ServerJson(*info), json);
    return absl::OkStatus();
  }
  if (verb == "info") {
    auto info = c.Get(in.target);
    if (!info.ok()) return info.status();
    Print(InfoJson(*info), json);
    return absl::OkStatus();
  }
  if (verb == "delete") {
    if (absl::Status s = c.Delete(in.target); !s.ok()) return s;
    if (json) {
      std::cout
          << nlohmann::json{{"session_id", in.target}, {"deleted", true}}.dump()
          << "\n";
    }
    return absl::OkStatus();
  }
  if (verb == "update") return Update(c, in);
  return absl::InvalidArgumentError(
      absl::StrCat("unknown remote verb '", verb, "'"));
}

void AddRemoteFlags(CLI::App* app, RemoteFlags* f) {
  app->add_option("--server", f->server, "server address host:port")
      ->capture_default_str();
  app->add_option("--tls-ca-file", f->tls_ca_file,
                  "connect with TLS, trusting this PEM CA");
  app->add_option("--tls-cert-file", f->tls_cert_file,
                  "client certificate (PEM) for mutual TLS");
  app->add_option("--tls-key-file", f->tls_key_file,
                  "private key (PEM) of --tls-cert-file");
  app->add_option("--token-file", f->token_file,
                  "file whose first line is the bearer token (default: the "
                  "MESHGAUGE_TOKEN environment variable)");
  app->add_option(
         "--connect-timeout", f->connect_timeout,
         absl::StrCat("seconds a call waits for a connection (server down, "
                      "wrong address, TLS mismatch) before it fails (default ",
                      client::ClientOptions{}.connect_timeout_seconds, ")"))
      ->check(Positive());
}

}  // namespace meshgauge::cli
