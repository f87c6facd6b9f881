// The server against an attacker: authentication, tenant isolation, bounded
// uploads, replies over the message limit, TLS, start-up on a taken port,
// escaped ids, overflowing meshes. Every test plays the attacker and checks
// what the attacker and the victim see.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "lib/core/sensitivity.h"
#include "lib/core/shapes.h"
#include "lib/embree/gradcheck.h"
#include "lib/embree/sdf_evaluator.h"
#include "server/auth.h"
#include "server/upload_watch.h"
#include "tests/fake_clock.h"
#include "tests/server_test_util.h"
#include "tests/tls_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Code;
using client::ClientOptions;
using client::RemoteClient;
using ::testing::HasSubstr;
using testing::MetricValue;
using ::testing::Not;

std::string TempFile(const std::string& name, const std::string& text) {
  const std::string path =
      (std::filesystem::temp_directory_path() /
       ("meshgauge_sec_" + std::to_string(::getpid()) + "_" + name))
          .string();
  std::ofstream(path) << text;
  return path;
}

class SecurityTest : public testing::ServerFixture {
 protected:
  void SetUp() override {
    server::ServerOptions o;
    o.auth_tokens_file =
        TempFile("tokens", "# tenant sha256(token)\nalice " +
                               server::Sha256Hex("alice-secret") + "\nbob " +
                               server::Sha256Hex("bob-secret") + "\n");
    StartServer(o);
    alice_ = Client("alice-secret");
    bob_ = Client("bob-secret");
  }
  std::unique_ptr<RemoteClient> Client(const std::string& token) {
    ClientOptions o;
    o.token = token;
    return std::make_unique<RemoteClient>(target_, o);
  }
  // Restarts the server with this memory budget, then
  // alice uploads `mesh` as each of `alice_ids` and bob as each of
  // `bob_ids`, a second apart in that order (later is more recently used).
  void RestartWithSessions(int64_t budget, const Mesh& mesh,
                           const std::vector<std::string>& alice_ids,
                           const std::vector<std::string>& bob_ids) {
    server::ServerOptions o = options_;
    o.memory_budget_bytes = budget;
    RestartServer(o);
    alice_ = Client("alice-secret");
    bob_ = Client("bob-secret");
    for (const auto& [client, ids] : {std::pair{alice_.get(), &alice_ids},
                                      std::pair{bob_.get(), &bob_ids}}) {
      for (const std::string& id : *ids) {
        ASSERT_TRUE(client->Upload(mesh, id).ok()) << id;
        clock_.Advance(1);
      }
    }
  }
  std::unique_ptr<RemoteClient> alice_, bob_;
};

// Tenants never slow each other much: alice's eight passes run two at a
// time (--max_computations_per_tenant 2), so bob's pass of the same size,
// sent after hers started, shares the cores with two passes, not eight,
// and ends before most of hers. Checked by order of completion: without the
// cap all nine share the cores and bob, last to start, ends among the last.
TEST_F(SecurityTest, ATenantsCallIsNotQueuedBehindAnothersPasses) {
  server::ServerOptions o = options_;
  o.max_computations_per_tenant = 2;
  o.max_concurrent_computations = 16;
  RestartServer(o);
  alice_ = Client("alice-secret");
  bob_ = Client("bob-secret");
  const Mesh mesh = MakeIcosphere(1, 40);  // 16,002 vertices.
  ASSERT_TRUE(alice_->Upload(mesh, "a").ok());
  ASSERT_TRUE(bob_->Upload(mesh, "b").ok());
  std::mutex mu;
  std::vector<std::string> finished;
  auto note = [&](const std::string& who) {
    std::lock_guard<std::mutex> lock(mu);
    finished.push_back(who);
  };
  std::vector<std::thread> calls;
  for (int i = 0; i < 8; ++i) {
    calls.emplace_back([&, i] {
      auto c = Client("alice-secret");
      SdfParams p;
      p.rays = 20 + i;  // eight different passes.
      EXPECT_TRUE(c->ComputeSdf("a", p).ok());
      note("alice");
    });
  }
  // Bob's call once alice's fill her slots and queue.
  for (int k = 0; k < 500 && server_->service().slots().waiting() < 6; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  SdfParams p;
  p.rays = 24;
  EXPECT_TRUE(bob_->ComputeSdf("b", p).ok());
  note("bob");
  for (std::thread& t : calls) t.join();
  const auto bob = std::find(finished.begin(), finished.end(), "bob");
  EXPECT_LE(bob - finished.begin(), 4) << absl::StrJoin(finished, " ");
}

// A tenant's reserved but unsent bytes count against its own share: its
// header-only upload of a large file (8 bytes reserved per declared byte:
// the whole server's budget) refuses none of another tenant's uploads
// (they were RESOURCE_EXHAUSTED until its idle timeout). The store's rule
// on both backends: SessionStoreTest.ASilentReservationBlocksNoOtherTenant.
TEST_F(SecurityTest, ASilentReservationBlocksNoOtherTenant) {
  server::ServerOptions o = options_;
  o.memory_budget_bytes = int64_t{64} << 20;
  RestartServer(o);
  alice_ = Client("alice-secret");
  bob_ = Client("bob-secret");
  grpc::ClientContext ctx;
  ctx.AddMetadata("authorization", "Bearer alice-secret");
  v1::CreateSessionResponse resp;
  auto w = alice_->stub().CreateSession(&ctx, &resp);
  v1::CreateSessionRequest header;
  header.mutable_header()->set_file_format("obj");
  header.mutable_header()->set_file_bytes(int64_t{8} << 20);  // x8: 64 MiB.
  ASSERT_TRUE(w->Write(header));
  testing::WaitFor([&] { return server_->store().reserved_uploads() >= 1; });
  ASSERT_EQ(server_->store().reserved_uploads(), 1);
  auto bob = bob_->Upload(MakeIcosphere(1, 20), "bob");
  EXPECT_TRUE(bob.ok()) << bob.status();
  // Alice's own next upload meets her reservation.
  auto alice = alice_->Upload(MakeIcosphere(1, 20), "alice");
  EXPECT_EQ(Code(alice), absl::StatusCode::kResourceExhausted);
  ctx.TryCancel();
  w->Finish();
}

TEST_F(SecurityTest, CallsWithoutAValidTokenAreUnauthenticated) {
  const Mesh m = MakeIcosphere(1, 2);
  EXPECT_EQ(Code(client_->Upload(m, "x")), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(Code(client_->List()), absl::StatusCode::kUnauthenticated);
  auto wrong = Client("guessed-token");
  auto r = wrong->Upload(m, "x");
  EXPECT_EQ(Code(r), absl::StatusCode::kUnauthenticated);
  EXPECT_THAT(std::string(r.status().message()), Not(HasSubstr("guessed")));
  // Health needs no token (load balancers and container checks).
  auto serving = client_->Serving();
  ASSERT_TRUE(serving.ok()) << serving.status();
  EXPECT_TRUE(*serving);
}

// Two authorization entries (one valid, one not, in either order) do not
// let the caller pick the one that is checked.
TEST_F(SecurityTest, TwoAuthorizationEntriesAreUnauthenticated) {
  ASSERT_TRUE(alice_->Upload(MakeIcosphere(1, 1), "mine").ok());
  for (bool valid_first : {true, false}) {
    grpc::ClientContext ctx;
    ctx.AddMetadata("authorization",
                    valid_first ? "Bearer alice-secret" : "Bearer wrong");
    ctx.AddMetadata("authorization",
                    valid_first ? "Bearer wrong" : "Bearer alice-secret");
    v1::GetSessionRequest req;
    req.set_session_id("mine");
    v1::GetSessionResponse resp;
    const grpc::Status s = client_->stub().GetSession(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::UNAUTHENTICATED);
    EXPECT_THAT(s.error_message(), HasSubstr("more than one"));
  }
}

TEST_F(SecurityTest, TenantsNeverSeeEachOthersSessions) {
  const Mesh victim_mesh = MakeIcosphere(1, 3);
  ASSERT_TRUE(alice_->Upload(victim_mesh, "shared-name").ok());
  auto assigned = alice_->Upload(victim_mesh);
  ASSERT_TRUE(assigned.ok());
  const std::string hidden = assigned->session_id;
  auto before = alice_->ComputeSdf("shared-name", SdfParams{});
  ASSERT_TRUE(before.ok());
  // Bob lists nothing, and every call on Alice's ids is NOT_FOUND with the
  // same message as for an id nobody has.
  auto listed = bob_->List();
  ASSERT_TRUE(listed.ok());
  EXPECT_TRUE(listed->empty());
  for (const std::string& id : {std::string("shared-name"), hidden}) {
    EXPECT_EQ(Code(bob_->Get(id)), absl::StatusCode::kNotFound);
    EXPECT_EQ(Code(bob_->ComputeSdf(id, SdfParams{})),
              absl::StatusCode::kNotFound);
    std::vector<Vec3> moved = victim_mesh.positions;
    for (Vec3& p : moved) p *= 0.5;
    EXPECT_EQ(Code(bob_->UpdatePositions(id, 0, 3, moved)),
              absl::StatusCode::kNotFound);
    EXPECT_EQ(Code(bob_->Delete(id)), absl::StatusCode::kNotFound);
    EXPECT_EQ(Code(bob_->GradCheck(id, SdfParams{}, {.samples = 1})),
              absl::StatusCode::kNotFound);
  }
  auto missing = bob_->Get("nobody-has-this");
  auto theirs = bob_->Get("shared-name");
  EXPECT_EQ(std::string(theirs.status().message()),
            absl::StrReplaceAll(std::string(missing.status().message()),
                                {{"nobody-has-this", "shared-name"}}));
  // No squatting: Bob's own "shared-name" is a different session.
  ASSERT_TRUE(bob_->Upload(MakeIcosphere(2, 2), "shared-name").ok());
  std::vector<Vec3> moved = MakeIcosphere(2, 2).positions;
  for (Vec3& p : moved) p *= 0.5;
  ASSERT_TRUE(bob_->UpdatePositions("shared-name", 0, 3, moved).ok());
  // Alice's session is untouched: same generation, same values bit for bit.
  auto info = alice_->Get("shared-name");
  ASSERT_TRUE(info.ok());
  EXPECT_EQ(info->generation, 0);
  EXPECT_EQ(info->num_vertices, victim_mesh.num_vertices());
  auto after = alice_->ComputeSdf("shared-name", SdfParams{});
  ASSERT_TRUE(after.ok());
  EXPECT_EQ(after->result.values, before->result.values);
  EXPECT_EQ(alice_->List()->size(), 2u);
}

TEST_F(SecurityTest, PerTenantSessionLimit) {
  server::ServerOptions o = options_;
  o.max_sessions_per_tenant = 1;
  RestartServer(o);
  alice_ = Client("alice-secret");
  bob_ = Client("bob-secret");
  const Mesh m = MakeIcosphere(1, 2);
  ASSERT_TRUE(alice_->Upload(m, "a1").ok());
  auto second = alice_->Upload(m, "a2");
  EXPECT_EQ(Code(second), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(second.status().message()),
              HasSubstr("--max_sessions_per_tenant"));
  EXPECT_TRUE(bob_->Upload(m, "b1").ok()) << "Alice's limit is not Bob's";
}

// One tenant filling the memory budget evicts its own sessions first: the
// other tenant's session stays although it is the least recently used.
TEST_F(SecurityTest, ATenantFillingTheBudgetEvictsItsOwnSessionsFirst) {
  const Mesh sphere = MakeIcosphere(1, 10);
  server::ServerOptions o = options_;
  o.memory_budget_bytes = server::Session::EstimateBaseBytes(sphere) * 7 / 2;
  RestartServer(o);
  alice_ = Client("alice-secret");
  bob_ = Client("bob-secret");
  ASSERT_TRUE(alice_->Upload(sphere, "a1").ok());
  for (int i = 1; i <= 4; ++i) {
    clock_.Advance(1);
    ASSERT_TRUE(bob_->Upload(sphere, "b" + std::to_string(i)).ok());
  }
  EXPECT_TRUE(alice_->Get("a1").ok());
  EXPECT_EQ(Code(bob_->Get("b1")), absl::StatusCode::kNotFound);
  EXPECT_EQ(Code(bob_->Get("b2")), absl::StatusCode::kNotFound);
  EXPECT_TRUE(bob_->Get("b3").ok());
  EXPECT_TRUE(bob_->Get("b4").ok());
}

// A gradcheck's scratch memory counts as its tenant's: room is made from
// the tenant holding the most (here bob, the caller), never from a smaller
// tenant; when bob has nothing left to give, the check is refused.
TEST_F(SecurityTest, AGradCheckNeverEvictsASmallerTenant) {
  const Mesh sphere = MakeIcosphere(1, 10);
  const int64_t base = server::Session::EstimateBaseBytes(sphere);
  const int64_t scratch = base + GradCheckWorkBytes(sphere, SdfParams{});
  RestartWithSessions(2 * base + scratch + base / 2, sphere, {"a"},
                      {"old", "k"});
  ASSERT_EQ(Code(alice_->Get("a")), absl::StatusCode::kOk);
  // A request the check refuses claims nothing, so it evicts nothing.
  GradCheckOptions bad;
  bad.vertices = {static_cast<int32_t>(sphere.num_vertices())};
  EXPECT_EQ(Code(bob_->GradCheck("k", SdfParams{}, bad)),
            absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(bob_->Get("old").ok());
  // Bob's check fits once bob's older session is evicted.
  auto checked = bob_->GradCheck("k", SdfParams{}, {.samples = 1});
  EXPECT_TRUE(checked.ok()) << checked.status();
  EXPECT_EQ(Code(bob_->Get("old")), absl::StatusCode::kNotFound);
  EXPECT_TRUE(alice_->Get("a").ok());
  // Now bob has only the session checked: alice's is not taken instead.
  clock_.Advance(1);
  ASSERT_TRUE(alice_->Upload(sphere, "a2").ok());
  auto refused = bob_->GradCheck("k", SdfParams{}, {.samples = 1});
  EXPECT_EQ(Code(refused), absl::StatusCode::kResourceExhausted);
  EXPECT_TRUE(alice_->Get("a").ok());
  EXPECT_TRUE(alice_->Get("a2").ok());
  EXPECT_TRUE(bob_->Get("k").ok());
}

// A ray pass's hit table (5 bytes a ray) is claimed against the memory
// budget before it is traced, by the gradcheck's rule: bob's pass of 1024
// rays a vertex evicts bob's older session when that makes room, never
// alice's; a pass that cannot fit is refused, nothing traced or evicted
// (it used to be traced, stored, and then made room by evicting alice).
TEST_F(SecurityTest, ARayPassNeverEvictsASmallerTenant) {
  const Mesh sphere = MakeIcosphere(1, 10);
  const int64_t base = server::Session::EstimateBaseBytes(sphere);
  SdfParams many;
  many.rays = 1024;
  const int64_t pass = EstimatePassBytes(sphere, many);
  ASSERT_GT(pass, 2 * base) << "the pass must outweigh a session";
  RestartWithSessions(2 * base + pass + base / 2, sphere, {"a"}, {"old", "b"});
  auto traced = bob_->ComputeSdf("b", many);
  ASSERT_TRUE(traced.ok()) << traced.status();
  EXPECT_EQ(Code(bob_->Get("old")), absl::StatusCode::kNotFound);
  EXPECT_TRUE(alice_->Get("a").ok());
  EXPECT_GE(bob_->Get("b")->memory_bytes, base + pass);

  // Room for the two sessions but not for the pass.
  RestartWithSessions(2 * base + pass / 2, sphere, {"a"}, {"b"});
  const double rays =
      MetricValue(metrics_.Text(), "meshgauge_rays_traced_total");
  auto refused = bob_->ComputeSdf("b", many);
  EXPECT_EQ(Code(refused), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(refused.status().message()),
              HasSubstr("ray pass's hit table"));
  EXPECT_EQ(MetricValue(metrics_.Text(), "meshgauge_rays_traced_total"), rays);
  EXPECT_TRUE(alice_->Get("a").ok());
  EXPECT_TRUE(bob_->Get("b").ok());
  // The default 100 rays fit.
  EXPECT_TRUE(bob_->ComputeSdf("b", SdfParams{}).ok());
  EXPECT_TRUE(alice_->Get("a").ok());
}

// A Jacobian asked with ComputeSdf is claimed (JacobianBytesBound) before
// it is made, by the same rule: one that cannot fit is refused and evicts
// nobody, where before it was made without being counted at all.
TEST_F(SecurityTest, AJacobianThatCannotFitIsRefusedBeforeItIsMade) {
  const Mesh sphere = MakeIcosphere(1, 10);
  const int64_t base = server::Session::EstimateBaseBytes(sphere);
  const int64_t pass = EstimatePassBytes(sphere, SdfParams{});
  int64_t jacobian = 0;
  {
    auto ev = SdfEvaluator::Create(sphere);
    HitTable hits;
    ASSERT_TRUE((*ev)->Compute({}, {}, &hits).ok());
    jacobian = *JacobianBytesBound(**ev, hits);
  }
  RestartWithSessions(2 * base + pass + jacobian / 2, sphere, {"a"}, {"b"});
  auto refused = bob_->ComputeSdf("b", SdfParams{}, {.include_jacobian = true});
  EXPECT_EQ(Code(refused), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(refused.status().message()),
              HasSubstr("this Jacobian"));
  EXPECT_TRUE(alice_->Get("a").ok());
  EXPECT_TRUE(bob_->Get("b").ok());
  // The values alone fit (the pass traced for the refused call is cached).
  auto values = bob_->ComputeSdf("b", SdfParams{});
  ASSERT_TRUE(values.ok()) << values.status();
  EXPECT_TRUE(values->facts.reused_hits);
  EXPECT_TRUE(alice_->Get("a").ok());
}

// Data of an upload in flight counts as its tenant's: bob's upload evicts
// bob's session, never alice's, although alice holds more sessions.
TEST_F(SecurityTest, AnUploadInFlightNeverEvictsASmallerTenant) {
  server::ServerOptions o = options_;
  o.memory_budget_bytes = 1 << 20;
  RestartServer(o);
  alice_ = Client("alice-secret");
  bob_ = Client("bob-secret");
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(
        alice_->Upload(MakeIcosphere(1, 4), "a" + std::to_string(i)).ok());
    clock_.Advance(1);
  }
  ASSERT_TRUE(bob_->Upload(MakeIcosphere(1, 7), "b").ok());
  grpc::ClientContext ctx;
  ctx.AddMetadata("authorization", "Bearer bob-secret");
  v1::CreateSessionResponse resp;
  auto w = bob_->stub().CreateSession(&ctx, &resp);
  v1::CreateSessionRequest header;
  header.mutable_header()->set_dimension(3);
  header.mutable_header()->set_num_vertices(12000);
  header.mutable_header()->set_num_faces(1);
  ASSERT_TRUE(w->Write(header));
  v1::CreateSessionRequest chunk;
  for (int i = 0; i < 3 * 3000; ++i) chunk.mutable_chunk()->add_positions(i);
  for (int k = 0; k < 4 && w->Write(chunk); ++k) {
  }
  // The upload's data (about 390 kB) arrived: the budget needs room.
  testing::WaitFor(
      [&] { return Code(bob_->Get("b")) == absl::StatusCode::kNotFound; });
  EXPECT_EQ(Code(bob_->Get("b")), absl::StatusCode::kNotFound);
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(alice_->Get("a" + std::to_string(i)).ok()) << i;
  }
  ctx.TryCancel();
  w->Finish();
}

TEST(AuthenticatorTest, RejectsMalformedTokenFiles) {
  EXPECT_THAT(std::string(server::Authenticator::FromText("alice xyz\n", "f")
                              .status()
                              .message()),
              HasSubstr("f: line 1: the token hash must be 64 hex digits"));
  const std::string h = server::Sha256Hex("t");
  EXPECT_THAT(std::string(server::Authenticator::FromText(
                              "a " + h + "\nb " + h + "\n", "f")
                              .status()
                              .message()),
              HasSubstr("line 2: this token hash is already listed"));
  EXPECT_THAT(
      std::string(
          server::Authenticator::FromText("# none\n", "f").status().message()),
      HasSubstr("no tenants"));
  EXPECT_EQ(server::Sha256Hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

// A rotation lists a tenant's old and new token; Reload swaps the whole
// table and keeps it when the new file is malformed.
TEST(AuthenticatorTest, ReloadRotatesATenantsTokenAndKeepsTheOldTableOnError) {
  auto as = [](const server::Authenticator& a, const std::string& token) {
    const std::string value = "Bearer " + token;
    std::multimap<grpc::string_ref, grpc::string_ref> md;
    md.emplace("authorization", value);
    return a.AuthenticateMetadata(md);
  };
  const std::string path =
      ::testing::TempDir() + "/meshgauge-tokens-" + std::to_string(::getpid());
  auto write = [&](const std::string& text) { std::ofstream(path) << text; };
  write("alice " + server::Sha256Hex("old") + "\n");
  auto auth = server::Authenticator::FromFile(path);
  ASSERT_TRUE(auth.ok()) << auth.status();
  EXPECT_EQ(as(*auth, "new").status().code(),
            absl::StatusCode::kUnauthenticated);
  write("alice " + server::Sha256Hex("old") + "\nalice " +
        server::Sha256Hex("new") + "\n");
  ASSERT_TRUE(auth->Reload(path).ok());
  EXPECT_EQ(*as(*auth, "old"), "alice");
  EXPECT_EQ(*as(*auth, "new"), "alice");
  write("alice " + server::Sha256Hex("new") + "\n");
  ASSERT_TRUE(auth->Reload(path).ok());
  EXPECT_EQ(as(*auth, "old").status().code(),
            absl::StatusCode::kUnauthenticated);
  write("alice nothex\n");
  EXPECT_EQ(auth->Reload(path).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(*as(*auth, "new"), "alice");
  server::Authenticator open;
  EXPECT_EQ(open.Reload(path).code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(*as(open, "anything"), "");
  std::remove(path.c_str());
}

// Refused callers' remainders: a cap of their own (they take no upload
// slot), and bounds on bytes and time.
TEST(UploadWatchTest, DiscardsAreCappedApartFromUploadsAndBounded) {
  server::ServerOptions o;
  o.max_concurrent_uploads = 1;
  testing::FakeClock clock;
  server::UploadWatch watch(o, &clock);
  std::vector<int64_t> discards;
  for (int i = 0; i < server::kMaxDiscards; ++i) {
    auto d = watch.StartDiscard(nullptr);
    ASSERT_TRUE(d.ok()) << d.status();
    discards.push_back(*d);
  }
  EXPECT_EQ(watch.StartDiscard(nullptr).status().code(),
            absl::StatusCode::kResourceExhausted);
  auto upload = watch.Start(nullptr);
  ASSERT_TRUE(upload.ok()) << upload.status();
  EXPECT_EQ(watch.Start(nullptr).status().code(),
            absl::StatusCode::kResourceExhausted);
  EXPECT_TRUE(watch.Touch(discards[0], server::kMaxDiscardBytes).ok());
  EXPECT_EQ(watch.Touch(discards[0], 1).code(), absl::StatusCode::kOutOfRange);
  clock.Advance(server::kMaxDiscardSeconds + 0.1);
  EXPECT_EQ(watch.Touch(discards[1], 1).code(), absl::StatusCode::kOutOfRange);
  EXPECT_TRUE(watch.Finish(discards[0]).ok());
  EXPECT_TRUE(watch.StartDiscard(nullptr).ok());
}

// Building and checking a received mesh is the server's work: an upload
// whose last message arrived is never aborted as idle, however long that
// takes (an outsider saw a valid 1M-vertex upload cancelled exactly
// --upload_idle_seconds after its last message). One still receiving is.
TEST(UploadWatchTest, TheIdleTimerStopsAtTheLastByte) {
  server::ServerOptions o;
  o.upload_idle_seconds = 30;
  testing::FakeClock clock;
  server::UploadWatch watch(o, &clock);
  auto received = watch.Start(nullptr);  // never cancelled: no context.
  ASSERT_TRUE(received.ok()) << received.status();
  ASSERT_TRUE(watch.Touch(*received, 1000).ok());
  watch.Received(*received);
  clock.Advance(10 * o.upload_idle_seconds);
  EXPECT_TRUE(watch.AbortIdle().empty());
  EXPECT_TRUE(watch.Finish(*received).ok());
}

// Tiny messages cost the server per message, not per byte: past the first
// 16, an upload's messages must average 4096 bytes.
TEST(UploadWatchTest, TinyMessagesAreRefusedPastTheFirstSixteen) {
  server::ServerOptions o;
  testing::FakeClock clock;
  server::UploadWatch watch(o, &clock);
  auto tiny = watch.Start(nullptr);
  ASSERT_TRUE(tiny.ok());
  for (int i = 0; i < server::kTinyMessagesAllowed; ++i) {
    ASSERT_TRUE(watch.Touch(*tiny, 10).ok()) << i;
  }
  const absl::Status refused = watch.Touch(*tiny, 10);
  EXPECT_EQ(refused.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(refused.message()), HasSubstr("averaging 10 bytes"));
  auto chunks = watch.Start(nullptr);
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(watch.Touch(*chunks, i == 0 ? 100 : 70000).ok()) << i;
  }
}

// Raw CreateSession streams, as an attacker writes them.
class UploadAttackTest : public testing::ServerFixture {
 protected:
  using Writer = grpc::ClientWriter<v1::CreateSessionRequest>;
  std::unique_ptr<Writer> Open(grpc::ClientContext* ctx,
                               v1::CreateSessionResponse* resp) {
    return client_->stub().CreateSession(ctx, resp);
  }
  // Ends the stream as clients do (a refusal waits for the client's end of
  // stream: see UploadReception::DiscardRest) and returns the status.
  static grpc::Status Close(Writer& w) {
    w.WritesDone();
    return w.Finish();
  }
  static v1::CreateSessionRequest Header(int64_t nv, int64_t nf,
                                         const std::string& id = "") {
    v1::CreateSessionRequest r;
    auto* h = r.mutable_header();
    h->set_session_id(id);
    h->set_dimension(3);
    h->set_num_vertices(nv);
    h->set_num_faces(nf);
    return r;
  }
  // With a 64 MiB budget, sends a header declaring more, then up to
  // `chunks` chunks of about 1 MiB while the writes succeed, and closes.
  // Returns the chunks written; *status, the call's.
  int64_t WritesAfterARefusedHeader(int64_t chunks, grpc::Status* status) {
    server::ServerOptions o;
    o.memory_budget_bytes = 64 << 20;
    RestartServer(o);
    grpc::ClientContext ctx;
    v1::CreateSessionResponse resp;
    auto w = Open(&ctx, &resp);
    int64_t written = -1;
    if (w->Write(Header(4'000'000, 8'000'000))) {
      v1::CreateSessionRequest chunk;
      for (int i = 0; i < 1 << 20; ++i) {
        chunk.mutable_chunk()->add_face_indices(0);
      }
      written = 0;
      while (written < chunks && w->Write(chunk)) ++written;
    }
    *status = Close(*w);
    return written;
  }
  // Sends one vertex every 0.15 s of the server's clock (never idle for
  // the 0.2 s allowed, about 100 bytes/s) until the server refuses; its
  // status.
  grpc::Status Trickle() {
    grpc::ClientContext ctx;
    v1::CreateSessionResponse resp;
    auto w = Open(&ctx, &resp);
    if (!w->Write(Header(1000, 1000))) return Close(*w);
    v1::CreateSessionRequest vertex;
    for (int i = 0; i < 3; ++i) vertex.mutable_chunk()->add_positions(0.5);
    for (int i = 0; i < 20; ++i) {
      clock_.Advance(0.15);
      if (!w->Write(vertex)) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(60));
    }
    return Close(*w);
  }
};

TEST_F(UploadAttackTest, DeclaredSizeOverTheBudgetIsRefusedAtTheHeader) {
  // The refusal comes at the header, before any data.
  grpc::Status s;
  EXPECT_EQ(WritesAfterARefusedHeader(0, &s), 0);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(s.error_message(), HasSubstr("memory budget"));
}

// A refusal before the client finished sending is sent after its stream
// ends (a proxy such as HAProxy 2.6 would give the client CANCELLED
// instead): every write of a 16 MiB remainder is taken, then the status.
// Without the discard, the writes fail once the server's reply resets the
// stream.
TEST_F(UploadAttackTest, ARefusedUploadIsReadToItsEndBeforeTheRefusal) {
  grpc::Status s;
  EXPECT_EQ(WritesAfterARefusedHeader(16, &s), 16);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(s.error_message(), HasSubstr("memory budget"));
}

// The remainder read is bounded: past kMaxDiscardBytes the refusal goes out
// and the writes fail.
TEST_F(UploadAttackTest, ARefusedUploadsRemainderIsReadOnlyToItsBound) {
  const int64_t limit = (server::kMaxDiscardBytes >> 20) + 16;
  grpc::Status s;
  const int64_t written = WritesAfterARefusedHeader(limit, &s);
  EXPECT_LT(written, limit);
  EXPECT_GE(written, limit - 20);  // the remainder was read up to its bound.
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
}

TEST_F(UploadAttackTest, IndicesWithoutSizesStopAtTheFirstExcessChunk) {
  grpc::ClientContext ctx;
  v1::CreateSessionResponse resp;
  auto w = Open(&ctx, &resp);
  ASSERT_TRUE(w->Write(Header(3, 1)));
  v1::CreateSessionRequest chunk;
  for (int i = 0; i < 1 << 20; ++i) chunk.mutable_chunk()->add_face_indices(0);
  int written = 0;
  while (written < 25 && w->Write(chunk)) ++written;
  const grpc::Status s = Close(*w);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(),
              HasSubstr("more face indices than the declared 1"));
  EXPECT_EQ(server_->store().reserved_uploads(), 0);
}

TEST_F(UploadAttackTest, UploadsInFlightCountAgainstTheSessionLimit) {
  server::ServerOptions o;
  o.max_sessions = 2;
  RestartServer(o);
  grpc::ClientContext c1, c2;
  v1::CreateSessionResponse r1, r2;
  auto w1 = Open(&c1, &r1);
  auto w2 = Open(&c2, &r2);
  ASSERT_TRUE(w1->Write(Header(3, 1)));
  ASSERT_TRUE(w2->Write(Header(3, 1)));
  testing::WaitFor([&] { return server_->store().reserved_uploads() >= 2; });
  ASSERT_EQ(server_->store().reserved_uploads(), 2);
  auto third = client_->Upload(MakeIcosphere(1, 1), "third");
  EXPECT_EQ(Code(third), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(third.status().message()), HasSubstr("in flight"));
  c1.TryCancel();
  c2.TryCancel();
  w1->Finish();
  w2->Finish();
  testing::WaitFor([&] { return server_->store().reserved_uploads() == 0; });
  EXPECT_EQ(server_->store().reserved_uploads(), 0);
  EXPECT_TRUE(client_->Upload(MakeIcosphere(1, 1), "third").ok());
}

TEST_F(UploadAttackTest, ConcurrentUploadsAreCapped) {
  server::ServerOptions o;
  o.max_concurrent_uploads = 1;
  RestartServer(o);
  grpc::ClientContext c1;
  v1::CreateSessionResponse r1;
  auto w1 = Open(&c1, &r1);
  ASSERT_TRUE(w1->Write(Header(3, 1)));
  testing::WaitFor([&] { return server_->store().reserved_uploads() >= 1; });
  auto second = client_->Upload(MakeIcosphere(1, 1), "second");
  EXPECT_EQ(Code(second), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(second.status().message()),
              HasSubstr("--max_concurrent_uploads"));
  c1.TryCancel();
  w1->Finish();
}

TEST_F(UploadAttackTest, AnIdleUploadIsAbortedAndReleased) {
  server::ServerOptions o;
  o.upload_idle_seconds = 0.2;  // checked every 0.05 s of real time.
  RestartServer(o);
  grpc::ClientContext ctx;
  v1::CreateSessionResponse resp;
  auto w = Open(&ctx, &resp);
  ASSERT_TRUE(w->Write(Header(3, 1)));
  testing::WaitFor([&] { return server_->store().reserved_uploads() >= 1; });
  ASSERT_EQ(server_->store().reserved_uploads(), 1);
  ::testing::internal::CaptureStderr();
  clock_.Advance(1);  // the upload is now idle on the server's clock.
  // Aborted while the client still holds the stream open.
  testing::WaitFor([&] { return server_->store().reserved_uploads() == 0; });
  EXPECT_EQ(server_->store().reserved_uploads(), 0);
  const grpc::Status s = Close(*w);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::CANCELLED);
  // The server's log names the flag and what the client sent (the client
  // itself sees CANCELLED: a stream the server cancels carries no status).
  const std::string log = ::testing::internal::GetCapturedStderr();
  EXPECT_THAT(log, HasSubstr("(--upload_idle_seconds 0.2)"));
  EXPECT_THAT(log, HasSubstr("bytes in"));
}

TEST_F(UploadAttackTest, ATrickleBelowTheMinimumRateIsAborted) {
  server::ServerOptions o;
  o.upload_idle_seconds = 0.2;  // checked every 0.05 s of real time.
  o.upload_min_bytes_per_second = 1000;
  RestartServer(o);
  const grpc::Status s = Trickle();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_THAT(s.error_message(), HasSubstr("--upload_min_bytes_per_second"));
  testing::WaitFor([&] { return server_->store().reserved_uploads() == 0; });
  EXPECT_EQ(server_->store().reserved_uploads(), 0);
}

TEST_F(UploadAttackTest, AnUploadPastItsDeadlineIsAborted) {
  server::ServerOptions o;
  o.upload_idle_seconds = 0.2;
  o.upload_deadline_seconds = 0.5;
  o.upload_min_bytes_per_second = 0;
  RestartServer(o);
  const grpc::Status s = Trickle();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_THAT(s.error_message(), HasSubstr("--upload_deadline_seconds"));
}

// A chunk whose arrays exceed the header's counts is refused whole: none
// of it is stored (the message names the chunk, not a running total).
TEST_F(UploadAttackTest, AChunkOverTheDeclaredCountsIsRefusedWhole) {
  struct Case {
    const char* field;
    std::function<void(v1::CreateSessionRequest::Chunk*)> fill;
  };
  const Case cases[] = {{"face sizes",
                         [](auto* c) {
                           for (int i = 0; i < 5; ++i) c->add_face_sizes(3);
                         }},
                        {"coordinates",
                         [](auto* c) {
                           for (int i = 0; i < 13; ++i) c->add_positions(1);
                         }},
                        {"face regions", [](auto* c) {
                           for (int i = 0; i < 5; ++i) c->add_face_regions(1);
                         }}};
  for (const Case& k : cases) {
    grpc::ClientContext ctx;
    v1::CreateSessionResponse resp;
    auto w = Open(&ctx, &resp);
    ASSERT_TRUE(w->Write(Header(4, 4)));
    v1::CreateSessionRequest chunk;
    k.fill(chunk.mutable_chunk());
    w->Write(chunk);
    const grpc::Status s = Close(*w);
    EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << k.field;
    EXPECT_THAT(s.error_message(), HasSubstr(k.field));
    EXPECT_THAT(s.error_message(), HasSubstr("declared 4"));
  }
}

// A header's reservation makes no room: the victim's session stays, also
// when a second reservation is then refused.
TEST_F(UploadAttackTest, AHeaderAloneEvictsNothing) {
  const Mesh sphere = MakeIcosphere(1, 10);
  const int64_t base = server::Session::EstimateBaseBytes(sphere);
  server::ServerOptions o;
  o.memory_budget_bytes = 3 * base;
  RestartServer(o);
  ASSERT_TRUE(client_->Upload(sphere, "victim").ok());
  // Each header declares about 2.5 sessions' worth.
  const int64_t nv = sphere.num_vertices() * 5 / 2,
                nf = sphere.num_faces() * 5 / 2;
  grpc::ClientContext c1, c2;
  v1::CreateSessionResponse r1, r2;
  auto w1 = Open(&c1, &r1);
  ASSERT_TRUE(w1->Write(Header(nv, nf)));
  testing::WaitFor([&] { return server_->store().reserved_uploads() >= 1; });
  EXPECT_TRUE(client_->Get("victim").ok());
  auto w2 = Open(&c2, &r2);
  w2->Write(Header(nv, nf));
  const grpc::Status refused = Close(*w2);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused.error_message(), HasSubstr("uploads in flight"));
  EXPECT_TRUE(client_->Get("victim").ok());
  EXPECT_THAT(
      metrics_.Text(),
      Not(HasSubstr("meshgauge_session_evictions_total{reason=\"memory\"} 1")));
  c1.TryCancel();
  w1->Finish();
  EXPECT_TRUE(client_->Get("victim").ok());
}

TEST_F(UploadAttackTest, DuplicateRegionDirectionsAreRejected) {
  grpc::ClientContext ctx;
  v1::CreateSessionResponse resp;
  auto w = Open(&ctx, &resp);
  v1::CreateSessionRequest h = Header(3, 1);
  for (int i = 0; i < 2; ++i) {
    auto* rd = h.mutable_header()->add_region_directions();
    rd->set_region(4);
    rd->set_direction(i == 0 ? v1::CONE_DIRECTION_INWARD
                             : v1::CONE_DIRECTION_OUTWARD);
  }
  w->Write(h);
  const grpc::Status s = Close(*w);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("region 4 is listed twice"));
}

class LimitsTest : public testing::ServerFixture {};

TEST_F(LimitsTest, RepliesOverTheMessageLimitAreRefusedBeforeComputing) {
  server::ServerOptions o;
  o.max_message_bytes = 64 << 10;
  RestartServer(o);
  ClientOptions co;
  co.upload_chunk_vertices = 1000;
  RemoteClient c(target_, co);
  const Mesh sphere = MakeIcosphere(1, 20);  // 4002 vertices: 96 kB replies.
  ASSERT_TRUE(c.Upload(sphere, "s").ok());
  auto vjp = c.ComputeVjp("s", SdfParams{},
                          std::vector<double>(sphere.num_vertices(), 1.0));
  EXPECT_EQ(Code(vjp), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(vjp.status().message()),
              HasSubstr("refused before computing"));
  auto pen = c.ComputePenalty("s", SdfParams{}, {.t_min = 1}, true);
  EXPECT_EQ(Code(pen), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(metrics_.Text(), HasSubstr("meshgauge_rays_traced_total 0"));
  // The SDF stream, with its Jacobian, is split to fit the limit instead.
  auto sdf = c.ComputeSdf("s", SdfParams{},
                          {.include_jacobian = true, .chunk_vertices = 4002});
  ASSERT_TRUE(sdf.ok()) << sdf.status();
  EXPECT_EQ(sdf->result.values.size(), 4002u);
  EXPECT_TRUE(sdf->jacobian.has_value());
}

// The smallest allowed message limit still streams every value: chunks end
// early to fit it (the server would otherwise fail after computing).
TEST_F(LimitsTest, SdfValueChunksFitTheMessageLimit) {
  server::ServerOptions o;
  o.max_message_bytes = 4096;
  RestartServer(o);
  ClientOptions co;
  co.upload_chunk_vertices = 50;
  RemoteClient c(target_, co);
  const Mesh sphere = MakeIcosphere(1, 10);
  ASSERT_TRUE(c.Upload(sphere, "s").ok());
  auto sdf = c.ComputeSdf("s", SdfParams{}, {.chunk_vertices = 65536});
  ASSERT_TRUE(sdf.ok()) << sdf.status();
  EXPECT_EQ(std::ssize(sdf->result.values), sphere.num_vertices());
  // With the Jacobian, one vertex's row at 1024 rays exceeds the limit: a
  // clear refusal before streaming, not gRPC's "larger than max".
  SdfParams many;
  many.rays = 1024;
  auto rows = c.ComputeSdf("s", many, {.include_jacobian = true});
  EXPECT_EQ(Code(rows), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(std::string(rows.status().message()),
              HasSubstr("Jacobian row takes about"));
}

// A header of empty region directions (2 bytes each on the wire, a heap
// object each once parsed) is refused unparsed past 1 MiB.
TEST_F(LimitsTest, AHeaderOfManyRegionDirectionsIsRefusedUnparsed) {
  grpc::ClientContext ctx;
  v1::CreateSessionResponse resp;
  auto w = client_->stub().CreateSession(&ctx, &resp);
  v1::CreateSessionRequest h;
  h.mutable_header()->set_dimension(3);
  h.mutable_header()->set_num_vertices(3);
  h.mutable_header()->set_num_faces(1);
  for (int i = 0; i < 600'000; ++i) h.mutable_header()->add_region_directions();
  w->Write(h);
  w->WritesDone();
  const grpc::Status s = w->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(s.error_message(), HasSubstr("region directions"));
}

TEST_F(LimitsTest, IdsWithControlCharactersAreEscapedInMessages) {
  auto r = client_->Get("evil\x01\x1b[2Jid");
  EXPECT_EQ(Code(r), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(r.status().message()),
              HasSubstr("evil\\x01\\x1b[2Jid"));
  EXPECT_THAT(std::string(r.status().message()), Not(HasSubstr("\x1b")));
  auto up = client_->Upload(MakeIcosphere(1, 1), "bad\nid");
  EXPECT_EQ(Code(up), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(up.status().message()), HasSubstr("bad\\nid"));
}

TEST_F(LimitsTest, AMeshTooLargeForDoublesIsNamedAsOverflow) {
  Mesh huge = MakeIcosphere(1, 2);
  for (Vec3& p : huge.positions) p *= 1e160;
  auto r = client_->Upload(huge, "huge");
  EXPECT_EQ(Code(r), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(r.status().message()),
              HasSubstr("too long for double precision"));
  EXPECT_THAT(std::string(r.status().message()), Not(HasSubstr("zero area")));
}

TEST(StartupTest, ATakenPortFailsCleanlyWithoutReusePort) {
  server::Metrics metrics;
  testing::FakeClock clock;
  server::ServerOptions a;
  a.address = "127.0.0.1:0";
  a.metrics_address = "";
  auto first = server::MeshGaugeServer::Start(a, &metrics, &clock);
  ASSERT_TRUE(first.ok());
  server::ServerOptions b = a;
  b.address = "127.0.0.1:" + std::to_string((*first)->port());
  server::Metrics metrics_b;
  auto second = server::MeshGaugeServer::Start(b, &metrics_b, &clock);
  EXPECT_EQ(Code(second), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(second.status().message()),
              HasSubstr("cannot listen on " + b.address));
  EXPECT_THAT(std::string(second.status().message()),
              HasSubstr("Address already in use"));
  for (const char* address :
       {"not an address:::", "127.0.0.1:99999", "127.0.0.1:", ":50051",
        "127.0.0.1:5x", "127.0.0.1:-1", "[::1:80", "unix:"}) {
    server::ServerOptions bad = a;
    bad.address = address;
    auto refused = server::MeshGaugeServer::Start(bad, &metrics_b, &clock);
    EXPECT_EQ(Code(refused), absl::StatusCode::kInvalidArgument) << address;
    EXPECT_THAT(std::string(refused.status().message()),
                HasSubstr("--address"));
  }
  server::ServerOptions limits = a;
  limits.max_message_bytes = -1;
  EXPECT_THAT(
      std::string(server::MeshGaugeServer::Start(limits, &metrics_b, &clock)
                      .status()
                      .message()),
      HasSubstr("--max_message_bytes must be in [4096, 2147483647]"));
}

class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(testing::MakeTestPki(&pki_)); }
  void TearDown() override {
    server_.reset();
    std::filesystem::remove_all(pki_.dir);
  }
  void Start(bool mutual) {
    options_.address = "127.0.0.1:0";
    options_.metrics_address = "";
    options_.drain_notice_seconds = 0;
    options_.tls_cert_file = pki_.server_crt;
    options_.tls_key_file = pki_.server_key;
    if (mutual) options_.tls_client_ca_file = pki_.ca_crt;
    auto s = server::MeshGaugeServer::Start(options_, &metrics_, &clock_);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = std::move(*s);
    target_ = "127.0.0.1:" + std::to_string(server_->port());
  }
  ClientOptions Tls(const std::string& ca, bool with_cert) {
    ClientOptions o;
    o.deadline_seconds = 5;
    o.retry = false;  // a refused handshake answers at once.
    o.tls_ca_pem = testing::ReadFileText(ca);
    if (with_cert) {
      o.tls_cert_pem = testing::ReadFileText(pki_.client_crt);
      o.tls_key_pem = testing::ReadFileText(pki_.client_key);
    }
    return o;
  }
  testing::TestPki pki_;
  server::ServerOptions options_;
  server::Metrics metrics_;
  testing::FakeClock clock_;
  std::unique_ptr<server::MeshGaugeServer> server_;
  std::string target_;
};

TEST_F(TlsTest, TlsServerServesTlsClientsOnly) {
  Start(/*mutual=*/false);
  RemoteClient good(target_, Tls(pki_.ca_crt, false));
  EXPECT_TRUE(good.Upload(MakeIcosphere(1, 1), "t").ok());
  ClientOptions plain;
  plain.deadline_seconds = 2;
  plain.retry = false;
  RemoteClient insecure(target_, plain);
  EXPECT_EQ(Code(insecure.Get("t")), absl::StatusCode::kUnavailable);
  // A client that trusts another CA refuses the server's certificate.
  RemoteClient wrong_ca(target_, Tls(pki_.other_ca_crt, false));
  EXPECT_EQ(Code(wrong_ca.Get("t")), absl::StatusCode::kUnavailable);
}

TEST_F(TlsTest, MutualTlsNeedsAClientCertificate) {
  Start(/*mutual=*/true);
  RemoteClient with_cert(target_, Tls(pki_.ca_crt, true));
  EXPECT_TRUE(with_cert.Upload(MakeIcosphere(1, 1), "m").ok());
  RemoteClient without(target_, Tls(pki_.ca_crt, false));
  EXPECT_EQ(Code(without.Get("m")), absl::StatusCode::kUnavailable);
}

TEST_F(TlsTest, UnreadableCertificateFilesFailTheStart) {
  options_.address = "127.0.0.1:0";
  options_.metrics_address = "";
  options_.tls_cert_file = pki_.dir + "/missing.crt";
  options_.tls_key_file = pki_.server_key;
  auto s = server::MeshGaugeServer::Start(options_, &metrics_, &clock_);
  EXPECT_EQ(Code(s), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(s.status().message()), HasSubstr("--tls_cert_file"));
}

}  // namespace
}  // namespace meshgauge
