// RemoteClient against a scripted service: a ComputeSdf stream cut after
// its reply started (its replica died; the channel's retry policy no longer
// applies) is asked again, at most three times in all, only for the codes
// of a dead peer and only with retries on.
#include "client/remote/remote_client.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>

#include "meshgauge/v1/meshgauge.grpc.pb.h"

namespace meshgauge {
namespace {

// Every ComputeSdf call sends one progress message, then ends with `cut`
// (the first `cuts` calls) or NOT_FOUND.
class CuttingService final : public v1::MeshGauge::Service {
 public:
  CuttingService(grpc::StatusCode cut, int cuts) : cut_(cut), cuts_(cuts) {}
  grpc::Status ComputeSdf(
      grpc::ServerContext*, const v1::ComputeSdfRequest*,
      grpc::ServerWriter<v1::ComputeSdfResponse>* writer) override {
    v1::ComputeSdfResponse progress;
    progress.mutable_progress()->set_vertices_total(10);
    writer->Write(progress);
    if (calls++ < cuts_) return grpc::Status(cut_, "Stream removed");
    return grpc::Status(grpc::StatusCode::NOT_FOUND, "no session");
  }
  std::atomic<int> calls{0};

 private:
  const grpc::StatusCode cut_;
  const int cuts_;
};

struct Scripted {
  Scripted(grpc::StatusCode cut, int cuts) : service(cut, cuts) {
    grpc::ServerBuilder b;
    b.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    b.RegisterService(&service);
    server = b.BuildAndStart();
  }
  ~Scripted() { server->Shutdown(); }
  absl::StatusCode Call(bool retry) {
    client::ClientOptions o;
    o.retry = retry;
    client::RemoteClient c("127.0.0.1:" + std::to_string(port), o);
    return c.ComputeSdf("s", SdfParams{}).status().code();
  }
  CuttingService service;
  int port = 0;
  std::unique_ptr<grpc::Server> server;
};

TEST(RemoteClientTest, AStreamCutAfterItStartedIsAskedAgain) {
  for (grpc::StatusCode cut :
       {grpc::StatusCode::UNAVAILABLE, grpc::StatusCode::UNKNOWN}) {
    Scripted s(cut, 1);
    EXPECT_EQ(s.Call(true), absl::StatusCode::kNotFound) << cut;
    EXPECT_EQ(s.service.calls, 2) << cut;
  }
}

TEST(RemoteClientTest, AStreamCutEveryTimeIsAskedThreeTimesInAll) {
  Scripted s(grpc::StatusCode::UNKNOWN, 100);
  EXPECT_EQ(s.Call(true), absl::StatusCode::kUnknown);
  EXPECT_EQ(s.service.calls, 3);
}

TEST(RemoteClientTest, OtherCodesAndNoRetriesEndTheCall) {
  Scripted invalid(grpc::StatusCode::INVALID_ARGUMENT, 1);
  EXPECT_EQ(invalid.Call(true), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(invalid.service.calls, 1);
  Scripted off(grpc::StatusCode::UNKNOWN, 1);
  EXPECT_EQ(off.Call(false), absl::StatusCode::kUnknown);
  EXPECT_EQ(off.service.calls, 1);
}

// No server: the call fails within the connection wait plus the retries,
// naming the target, not a bare "failed to connect" or a deadline.
TEST(RemoteClientTest, NoServerFailsFastNamingTheTarget) {
  // A loopback port that was free and is closed again.
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), len), 0);
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  const int port = ntohs(addr.sin_port);
  close(fd);
  client::ClientOptions o;
  o.connect_timeout_seconds = 1;
  const std::string target = "127.0.0.1:" + std::to_string(port);
  client::RemoteClient c(target, o);
  const auto start = std::chrono::steady_clock::now();
  const absl::Status s = c.Get("s").status();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
  EXPECT_EQ(s.code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(s.message().find("meshgauge server at " + target), std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find("is unavailable"), std::string::npos);
}

}  // namespace
}  // namespace meshgauge
