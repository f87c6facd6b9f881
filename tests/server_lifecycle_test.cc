// Server lifecycle: health, cancellation and deadlines inside long
// computations, metrics exposition, graceful drain with a call in flight.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>

#include "lib/core/shapes.h"
#include "tests/server_test_util.h"

namespace meshgauge {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// 1 SERVING, 2 NOT_SERVING, -1 on an RPC error.
int HealthStatus(const std::string& target) {
  client::RemoteClient c(target);
  auto serving = c.Serving();
  if (!serving.ok()) return -1;
  return *serving ? 1 : 2;
}

class LifecycleTest : public testing::ServerFixture {};

TEST_F(LifecycleTest, HealthIsServingAfterStart) {
  EXPECT_EQ(HealthStatus(target_), 1);
}

TEST_F(LifecycleTest, CancellationMidStreamStopsTheCall) {
  // ~20 MB of values and Jacobian rows: far more than HTTP/2 flow control
  // lets the server buffer, so it is still writing when the client cancels.
  ASSERT_TRUE(client_->Upload(MakeIcosphere(1, 60), "s").ok());
  auto ctx = client_->Context("s");
  v1::ComputeSdfRequest req;
  req.set_session_id("s");
  req.set_chunk_vertices(100);
  req.set_include_jacobian(true);
  auto reader = client_->stub().ComputeSdf(ctx.get(), req);
  v1::ComputeSdfResponse msg;
  ASSERT_TRUE(reader->Read(&msg));
  EXPECT_EQ(msg.chunk().vertex_end(), 100);
  ctx->TryCancel();
  while (reader->Read(&msg)) {
  }
  EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::CANCELLED);
  // The server recorded the cancelled call and still serves.
  testing::WaitFor([&] {
    return metrics_.Text().find("code=\"CANCELLED\",method=\"ComputeSdf\"") !=
           std::string::npos;
  });
  EXPECT_THAT(metrics_.Text(),
              HasSubstr("code=\"CANCELLED\",method=\"ComputeSdf\""));
  EXPECT_TRUE(client_->Get("s").ok());
}

// A deadline that passes inside the ray pass stops it: the server records
// DEADLINE_EXCEEDED (a pass that ran on would finish, trace its rays and
// then fail to stream: CANCELLED), counts no ray, and the exclusive update
// that waits for the computation goes through.
TEST_F(LifecycleTest, DeadlineStopsAComputationInsideTheRayPass) {
  const Mesh big = MakeIcosphere(1, 90);  // 81k vertices: seconds of rays.
  ASSERT_TRUE(client_->Upload(big, "big").ok());
  // Build the BVH first so the deadline falls inside the ray pass.
  ASSERT_TRUE(client_->UpdatePositions("big", 0, 3, big.positions).ok());
  client::ClientOptions fast;
  fast.deadline_seconds = 0.2;
  client::RemoteClient impatient(target_, fast);
  auto r = impatient.ComputeSdf("big", SdfParams{});
  EXPECT_EQ(r.status().code(), absl::StatusCode::kDeadlineExceeded);
  ASSERT_TRUE(client_->UpdatePositions("big", 1, 3, big.positions).ok());
  const std::string recorded =
      "code=\"DEADLINE_EXCEEDED\",method=\"ComputeSdf\"";
  testing::WaitFor(
      [&] { return metrics_.Text().find(recorded) != std::string::npos; });
  EXPECT_THAT(metrics_.Text(), HasSubstr(recorded));
  EXPECT_THAT(metrics_.Text(), HasSubstr("\nmeshgauge_rays_traced_total 0\n"));
}

TEST_F(LifecycleTest, MetricsUseBaseUnitsAndNoSessionIds) {
  ASSERT_TRUE(client_->Upload(MakeIcosphere(1, 4), "secret-session-name").ok());
  ASSERT_TRUE(client_->ComputeSdf("secret-session-name", SdfParams{}).ok());
  EXPECT_EQ(client_->Get("missing").status().code(),
            absl::StatusCode::kNotFound);
  const std::string text = metrics_.Text();
  EXPECT_THAT(
      text,
      HasSubstr(
          "meshgauge_rpc_requests_total{code=\"OK\",method=\"ComputeSdf\"} 1"));
  EXPECT_THAT(text, HasSubstr("meshgauge_rpc_requests_total{code=\"NOT_FOUND\","
                              "method=\"GetSession\"} 1"));
  EXPECT_THAT(
      text,
      HasSubstr(
          "meshgauge_rpc_duration_seconds_count{method=\"CreateSession\"} 1"));
  EXPECT_THAT(text, HasSubstr("meshgauge_sessions_active 1"));
  EXPECT_THAT(text, HasSubstr("meshgauge_rays_traced_total 16200"));
  EXPECT_THAT(text, HasSubstr("meshgauge_bvh_builds_total 1"));
  EXPECT_THAT(text, HasSubstr("meshgauge_bvh_build_seconds_count 1"));
  EXPECT_THAT(text, HasSubstr("meshgauge_session_cache_bytes"));
  EXPECT_THAT(text, Not(HasSubstr("secret-session-name")));
}

// process_start_time_seconds (a restart loop's alert counts its changes) is
// when the process's metrics were made, in seconds since the Unix epoch.
TEST(MetricsTest, StartTimeIsTheWallClockAtCreation) {
  auto now = [] {
    return std::chrono::duration<double>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
  };
  const double before = now();
  server::Metrics metrics;
  const double after = now();
  const std::string text = metrics.Text();
  const std::string key = "\nprocess_start_time_seconds ";
  const size_t at = text.find(key);
  ASSERT_NE(at, std::string::npos) << text;
  const double start = std::strtod(text.c_str() + at + key.size(), nullptr);
  EXPECT_GE(start, before - 1e-3);  // the text has millisecond precision.
  EXPECT_LE(start, after + 1e-3);
}

TEST_F(LifecycleTest, GracefulShutdownFinishesTheCallInFlight) {
  server::ServerOptions o;
  o.drain_notice_seconds = 0.5;
  o.shutdown_grace_seconds = 30;
  RestartServer(o);
  const Mesh big = MakeIcosphere(1, 110);  // 121k vertices: seconds of rays.
  ASSERT_TRUE(client_->Upload(big, "big").ok());
  std::promise<void> tracing;
  std::atomic<bool> told{false};
  auto in_flight = std::async(std::launch::async, [&] {
    client::RemoteClient c(target_);
    client::SdfCall call;
    call.progress = [&](int64_t, int64_t) {
      if (!told.exchange(true)) tracing.set_value();
    };
    return c.ComputeSdf("big", SdfParams{}, call);
  });
  // The server is tracing the call's rays.
  ASSERT_EQ(tracing.get_future().wait_for(std::chrono::seconds(60)),
            std::future_status::ready);
  auto shutdown = std::async(std::launch::async, [&] { server_->Shutdown(); });
  testing::WaitFor([&] { return HealthStatus(target_) == 2; });
  EXPECT_EQ(HealthStatus(target_), 2) << "NOT_SERVING while draining";
  // After the notice, with the call still in flight: a new call is refused
  // UNAVAILABLE (retryable), not CANCELLED.
  client::ClientOptions once;
  once.retry = false;  // see this attempt's status, not a later retry's.
  client::RemoteClient probe(target_, once);
  absl::Status refused;
  testing::WaitFor([&] {
    refused = probe.Get("big").status();
    return !refused.ok();
  });
  EXPECT_EQ(in_flight.wait_for(std::chrono::seconds(0)),
            std::future_status::timeout)
      << "the call must still be running when new calls are refused";
  EXPECT_EQ(refused.code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(refused.message()), HasSubstr("draining"));
  auto result = in_flight.get();
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->result.CountStatus(VertexStatus::kOk), big.num_vertices());
  shutdown.get();
  client::ClientOptions brief;
  brief.connect_timeout_seconds = 0.5;
  EXPECT_EQ(client::RemoteClient(target_, brief).Get("big").status().code(),
            absl::StatusCode::kUnavailable);
}

}  // namespace
}  // namespace meshgauge
