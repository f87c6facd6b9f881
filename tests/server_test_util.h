// An in-process meshgauge server on a free loopback port, with a fake clock.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "client/remote/remote_client.h"
#include "proto/wire/convert.h"
#include "proto/wire/upload_convert.h"
#include "server/server.h"
#include "tests/fake_clock.h"
#include "tests/wait_for.h"

namespace meshgauge::testing {

class ServerFixture : public ::testing::Test {
 protected:
  void StartServer(server::ServerOptions options = {}) {
    options_ = options;
    options_.address = "127.0.0.1:0";
    options_.metrics_address = "";
    options_.drain_notice_seconds =
        options.drain_notice_seconds == 1 ? 0.0 : options.drain_notice_seconds;
    auto s = server::MeshGaugeServer::Start(options_, &metrics_, &clock_);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = std::move(*s);
    target_ = "127.0.0.1:" + std::to_string(server_->port());
    client_ = std::make_unique<client::RemoteClient>(target_);
  }
  // Stops the fixture's server and starts one with `options`.
  void RestartServer(server::ServerOptions options) {
    TearDown();
    StartServer(options);
  }
  void SetUp() override { StartServer(); }
  void TearDown() override {
    client_.reset();
    server_.reset();
  }

  server::ServerOptions options_;
  server::Metrics metrics_;
  FakeClock clock_;
  std::unique_ptr<server::MeshGaugeServer> server_;
  std::string target_;
  std::unique_ptr<client::RemoteClient> client_;
};

// The value of an unlabelled counter or gauge in Prometheus text (0 when
// absent).
inline double MetricValue(const std::string& text, const std::string& name) {
  const size_t at = text.find("\n" + name + " ");
  if (at == std::string::npos) return 0;
  return std::stod(text.substr(at + name.size() + 2));
}

// Streams raw CreateSession messages (headers, chunks and footers as a
// test writes them) and returns the server's whole reply.
inline absl::StatusOr<v1::CreateSessionResponse> RawUploadResponse(
    client::RemoteClient& c,
    const std::vector<v1::CreateSessionRequest>& msgs) {
  auto ctx = c.Context("raw");
  v1::CreateSessionResponse response;
  auto w = c.stub().CreateSession(ctx.get(), &response);
  for (const auto& m : msgs) w->Write(m);
  w->WritesDone();
  if (absl::Status s = wire::FromGrpc(w->Finish()); !s.ok()) return s;
  return response;
}

// The same, returning the new session.
inline absl::StatusOr<v1::SessionInfo> RawUpload(
    client::RemoteClient& c,
    const std::vector<v1::CreateSessionRequest>& msgs) {
  auto response = RawUploadResponse(c, msgs);
  if (!response.ok()) return response.status();
  return response->session();
}

// The CreateSession messages of `mesh` as the clients write them.
inline std::vector<v1::CreateSessionRequest> UploadMessages(
    const Mesh& mesh, const std::string& session_id) {
  std::vector<v1::CreateSessionRequest> msgs;
  wire::WriteUpload(mesh, session_id, 1 << 16,
                    [&](const v1::CreateSessionRequest& m) {
                      msgs.push_back(m);
                      return true;
                    });
  return msgs;
}

}  // namespace meshgauge::testing
