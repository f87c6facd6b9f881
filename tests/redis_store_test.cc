// Sessions in Redis (--session_store) through the service: two replicas
// share one redis-server; any replica serves any session bit for bit like
// a single in-memory server, an applied update retried succeeds again, the
// TTL is global, uploads' claims are renewed, and an unreachable Redis is
// UNAVAILABLE with the cause, recovered when it returns (AOF). The store's
// contract on both backends: session_store_test.cc.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <random>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/remote/remote_client.h"
#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"
#include "server/record/record_convert.h"
#include "server/redis_records.h"
#include "server/server.h"
#include "tests/redis_test_util.h"
#include "tests/test_util.h"
#include "tests/wait_for.h"

namespace meshgauge {
namespace {

using testing::Knight;
using testing::Code;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::SameBits;

struct Replica {
  explicit Replica(server::ServerOptions o, int port = 0)
      : options(std::move(o)) {
    options.address = "127.0.0.1:" + std::to_string(port);
    options.metrics_address = "";
    options.drain_notice_seconds = 0;
    auto s = server::MeshGaugeServer::Start(options, &metrics, &clock);
    EXPECT_TRUE(s.ok()) << s.status();
    server = std::move(*s);
    client = std::make_unique<client::RemoteClient>(
        "127.0.0.1:" + std::to_string(server->port()));
  }
  server::ServerOptions options;
  server::Metrics metrics;
  server::SteadyClock clock;
  std::unique_ptr<server::MeshGaugeServer> server;
  std::unique_ptr<client::RemoteClient> client;
};

class RedisStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    redis_.Start();
    Start();
  }
  void Start(server::ServerOptions o = {}) {
    o.rebuild_every_updates = 3;  // cross BVH rebuilds within a test.
    o.session_store = redis_.url();
    a_ = std::make_unique<Replica>(o);
    b_ = std::make_unique<Replica>(o);
    o.session_store = "";
    memory_ = std::make_unique<Replica>(o);
  }
  // Options of a RedisRecords on the test's Redis.
  server::RedisOptions RecordsOptions() const {
    server::RedisOptions ro;
    EXPECT_TRUE(server::ParseRedisUrl(redis_.url(), &ro).ok());
    return ro;
  }
  // A small record (an icosphere) for the records' own tests.
  static server::SessionRecord SmallRecord(const std::string& id,
                                           const std::string& incarnation) {
    server::SessionRecord rec;
    rec.mesh = MakeIcosphere(1.0, 1);
    rec.info.session_id = id;
    rec.info.dimension = 3;
    rec.info.num_vertices = rec.mesh.num_vertices();
    rec.info.num_faces = rec.mesh.num_faces();
    rec.info.memory_bytes = 1000;
    rec.incarnation = incarnation;
    return rec;
  }
  static constexpr server::RecordLimits kRoomy{10, 10, 1 << 30};
  // The first message of a raw 3D upload.
  static v1::CreateSessionRequest UploadHeader(int64_t nv, int64_t nf) {
    v1::CreateSessionRequest r;
    r.mutable_header()->set_dimension(3);
    r.mutable_header()->set_num_vertices(nv);
    r.mutable_header()->set_num_faces(nf);
    return r;
  }
  // Moves vertices idx of `mesh` to `scale` times their first positions
  // through `writer` and on the in-memory server, both at `generation`.
  void MoveSubset(Replica& writer, const std::string& id, const Mesh& mesh,
                  const std::vector<int32_t>& idx, double scale,
                  int64_t generation = 0) {
    std::vector<Vec3> p;
    for (int32_t i : idx) p.push_back(mesh.positions[i] * scale);
    ASSERT_TRUE(writer.client->UpdatePositions(id, generation, 3, p, idx).ok());
    ASSERT_TRUE(
        memory_->client->UpdatePositions(id, generation, 3, p, idx).ok());
  }
  testing::RedisProcess redis_;
  std::unique_ptr<Replica> a_, b_, memory_;
};

// Positions of step k: a deterministic wobble of every vertex.
std::vector<Vec3> Moved(const Mesh& mesh, int k) {
  std::vector<Vec3> p = mesh.positions;
  const double d = 1e-3 * BoundingBoxDiagonal(mesh);
  for (size_t i = 0; i < p.size(); ++i) {
    p[i].x += d * std::sin(0.7 * k + 0.11 * i);
    p[i].z += d * std::cos(0.3 * k + 0.07 * i);
  }
  return p;
}

TEST_F(RedisStoreTest, AnyReplicaServesAnySessionBitForBit) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(a_->client->Upload(mesh, "k").ok());
  ASSERT_TRUE(memory_->client->Upload(mesh, "k").ok());
  std::vector<double> g(mesh.num_vertices());
  for (size_t i = 0; i < g.size(); ++i) g[i] = std::cos(0.3 * i);
  for (int k = 0; k < 8; ++k) {
    // Updates alternate replicas; every read goes to the other one.
    Replica& writer = k % 2 ? *a_ : *b_;
    Replica& reader = k % 2 ? *b_ : *a_;
    if (k > 0) {
      auto u = writer.client->UpdatePositions("k", k - 1, 3, Moved(mesh, k));
      ASSERT_TRUE(u.ok()) << u.status();
      EXPECT_EQ(u->generation, k);
      ASSERT_TRUE(
          memory_->client->UpdatePositions("k", k - 1, 3, Moved(mesh, k)).ok());
    }
    auto got =
        reader.client->ComputeSdf("k", SdfParams{}, {.expected_generation = k});
    auto want = memory_->client->ComputeSdf("k", SdfParams{},
                                            {.expected_generation = k});
    ASSERT_TRUE(got.ok()) << got.status();
    ASSERT_TRUE(want.ok()) << want.status();
    EXPECT_TRUE(SameBits(got->result.values, want->result.values))
        << "generation " << k;
    EXPECT_EQ(got->result.hits, want->result.hits);
    auto vg = writer.client->ComputeVjp("k", SdfParams{}, g, k);
    auto vw = memory_->client->ComputeVjp("k", SdfParams{}, g, k);
    ASSERT_TRUE(vg.ok() && vw.ok());
    EXPECT_EQ(vg->gradient, vw->gradient);
  }
  EXPECT_THAT(
      a_->metrics.Text(),
      HasSubstr("meshgauge_session_cache_requests_total{result=\"miss\"}"));
  EXPECT_THAT(b_->metrics.Text(), HasSubstr("meshgauge_session_load_seconds"));
}

// A replica that computed generation g and then serves generation g + 1
// (the update went through the other replica) restores the session from
// Redis and reuses its earlier pass: it traces only some rays, and its
// values, hits and statuses equal the in-memory server's bit for bit. The
// replicas take turns over a patch, one vertex and scattered vertices.
TEST_F(RedisStoreTest, AReplicaReusesItsPassOfAnEarlierGeneration) {
  const Mesh rocker = *ReadMesh(testing::SharedMesh("rocker-arm.obj"));
  ASSERT_TRUE(a_->client->Upload(rocker, "r").ok());
  ASSERT_TRUE(memory_->client->Upload(rocker, "r").ok());
  std::vector<int32_t> scattered;
  for (int32_t v = 0; v < rocker.num_vertices(); v += 101) {
    scattered.push_back(v);
  }
  const std::vector<std::vector<int32_t>> moves = {
      testing::Patch(rocker, 100, 0.05 * BoundingBoxDiagonal(rocker)),
      {4321},
      scattered};
  Replica* reader = a_.get();
  Replica* writer = b_.get();
  ASSERT_TRUE(reader->client->ComputeSdf("r", SdfParams{}).ok());
  for (size_t k = 0; k < moves.size(); ++k) {
    MoveSubset(*writer, "r", rocker, moves[k], 1.0 + 1e-3 * (k + 1),
               static_cast<int64_t>(k));
    const client::SdfCall call{.expected_generation =
                                   static_cast<int64_t>(k + 1)};
    auto got = reader->client->ComputeSdf("r", SdfParams{}, call);
    auto want = memory_->client->ComputeSdf("r", SdfParams{}, call);
    ASSERT_TRUE(got.ok()) << got.status();
    ASSERT_TRUE(want.ok()) << want.status();
    EXPECT_TRUE(SameBits(got->result.values, want->result.values)) << k;
    EXPECT_EQ(got->result.hits, want->result.hits) << k;
    EXPECT_EQ(got->result.status, want->result.status) << k;
    EXPECT_LT(got->result.rays_traced, rocker.num_vertices() * 100 / 2) << k;
    EXPECT_GT(got->result.rays_traced, 0) << k;
    // The writer computes next: it reuses its own pass of generation k.
    ASSERT_TRUE(writer->client->ComputeSdf("r", SdfParams{}, call).ok());
    std::swap(reader, writer);
  }
}

// An update retried on another replica after it was applied (its reply
// was lost) succeeds again with the same generation; the compare-and-set
// itself: SessionStoreTest.GenerationIsCompareAndSetAcrossReplicas.
TEST_F(RedisStoreTest, AnAppliedUpdateRetriedOnAnotherReplicaSucceedsAgain) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(a_->client->Upload(mesh, "cas").ok());
  ASSERT_TRUE(b_->client->Get("cas").ok());  // cached on both.
  auto first = a_->client->UpdatePositions("cas", 0, 3, Moved(mesh, 1));
  ASSERT_TRUE(first.ok()) << first.status();
  auto retried = b_->client->UpdatePositions("cas", 0, 3, Moved(mesh, 1));
  ASSERT_TRUE(retried.ok()) << retried.status();
  EXPECT_EQ(retried->generation, 1);
  EXPECT_EQ(b_->client->Get("cas")->generation, 1);
}

TEST_F(RedisStoreTest, SubsetUpdateOnOneReplicaIsSeenByTheOther) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(a_->client->Upload(mesh, "sub").ok());
  ASSERT_TRUE(memory_->client->Upload(mesh, "sub").ok());
  const std::vector<int32_t> idx = {3, 10, 200};
  MoveSubset(*a_, "sub", mesh, idx, 1.01);
  auto got =
      b_->client->ComputeSdf("sub", SdfParams{}, {.expected_generation = 1});
  auto want = memory_->client->ComputeSdf("sub", SdfParams{},
                                          {.expected_generation = 1});
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_TRUE(SameBits(got->result.values, want->result.values));
  // Validation happens before the record changes.
  const std::vector<Vec3> p(3, mesh.positions[3]);
  EXPECT_EQ(Code(b_->client->UpdatePositions("sub", 1, 3, p, {3, 3, 4})),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(a_->client->Get("sub")->generation, 1);
}

// An upload beyond the ray tracer's range is refused with the reason,
// rather than accepted and failing every call, whatever the store (a
// refused update: SessionStoreTest.RefusedUpdatesChangeNothing).
TEST_F(RedisStoreTest,
       AnUploadBeyondTheRayTracersRangeIsRefusedOnEitherBackend) {
  Mesh huge = Knight();
  for (Vec3& p : huge.positions) p *= 1e14;
  for (Replica* r : {memory_.get(), a_.get()}) {
    const auto up = r->client->Upload(huge, "huge");
    EXPECT_EQ(Code(up), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(up.status().message()),
                HasSubstr("single-precision ray tracing"));
  }
}

// The scenario of a stale incarnation: replica C caches session s1 (a
// knight), replica D deletes it and creates s1 again as a sphere, also at
// generation 0. C must serve the sphere and must never write the knight's
// positions into the sphere's record.
TEST_F(RedisStoreTest, ReCreatedSessionIsNeverServedOrWrittenFromAStaleCache) {
  const Mesh knight = Knight();
  const Mesh sphere = MakeIcosphere(1.0, 3);
  ASSERT_NE(knight.num_vertices(), sphere.num_vertices());
  Replica c(a_->options), d(a_->options);
  ASSERT_TRUE(a_->client->Upload(knight, "s1").ok());
  ASSERT_TRUE(c.client->ComputeSdf("s1", SdfParams{}).ok());  // C caches it.
  ASSERT_TRUE(d.client->Delete("s1").ok());
  ASSERT_TRUE(d.client->Upload(sphere, "s1").ok());
  ASSERT_TRUE(memory_->client->Upload(sphere, "s1").ok());

  auto info = c.client->Get("s1");
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->num_vertices, sphere.num_vertices());
  auto got = c.client->ComputeSdf("s1", SdfParams{});
  auto want = memory_->client->ComputeSdf("s1", SdfParams{});
  ASSERT_TRUE(got.ok() && want.ok());
  EXPECT_TRUE(SameBits(got->result.values, want->result.values));
  auto listed = c.client->List();
  ASSERT_TRUE(listed.ok());
  ASSERT_EQ(listed->size(), 1u);
  EXPECT_EQ((*listed)[0].num_vertices, sphere.num_vertices());
  // The knight's positions, at the generation C last saw.
  EXPECT_EQ(Code(c.client->UpdatePositions("s1", 0, 3, Moved(knight, 1))),
            absl::StatusCode::kInvalidArgument);
  for (Replica* r : {&d, a_.get(), b_.get()}) {
    auto after = r->client->ComputeSdf("s1", SdfParams{});
    ASSERT_TRUE(after.ok()) << after.status();
    EXPECT_TRUE(SameBits(after->result.values, want->result.values));
  }
}

// The record's compare-and-set itself refuses an update checked against
// another incarnation (the session was deleted and created again between
// a replica's read and its commit).
TEST_F(RedisStoreTest, CommitToAnotherIncarnationIsAborted) {
  server::RedisRecords records(RecordsOptions());
  server::SessionRecord rec = SmallRecord("inc", "first");
  ASSERT_TRUE(records.Create("", rec, kRoomy, "").ok());
  auto version = records.Version("", "inc", false);
  ASSERT_TRUE(version.ok());
  EXPECT_EQ(version->incarnation, "first");
  auto stale = records.CommitPositions("", "inc", {0, "second"},
                                       rec.mesh.positions, false);
  EXPECT_EQ(Code(stale), absl::StatusCode::kAborted);
  EXPECT_THAT(std::string(stale.status().message()),
              HasSubstr("deleted and created again"));
  EXPECT_EQ(records.Version("", "inc", false)->generation, 0);
  auto fresh = records.CommitPositions("", "inc", {0, "first"},
                                       rec.mesh.positions, false);
  ASSERT_TRUE(fresh.ok()) << fresh.status();
  EXPECT_EQ(*fresh, 1);
}

// An update costs one lookup and one compare-and-set in Redis: the
// service passes the session it found to the store (it looked it up twice).
TEST_F(RedisStoreTest, AnUpdateIsOneLookupAndOneCommit) {
  const Mesh knight = Knight();
  ASSERT_TRUE(a_->client->Upload(knight, "one").ok());
  ASSERT_TRUE(a_->client->Get("one").ok());  // cached on a.
  const int64_t before = redis_.ScriptCalls();
  auto update = a_->client->UpdatePositions("one", 0, 3, knight.positions);
  ASSERT_TRUE(update.ok()) << update.status();
  EXPECT_EQ(redis_.ScriptCalls() - before, 2);
}

// Delete and re-create races under load: one client keeps deleting s1 and
// creating it again as a knight or a sphere through one replica while two
// others read and update it through two other replicas. Every reply is
// checked against the mesh it claims to be: its values are that mesh's,
// bit for bit; no call ever meets a corrupt record.
TEST_F(RedisStoreTest, DeleteAndReCreateRacesNeverMixIncarnations) {
  const Mesh meshes[2] = {Knight(), MakeIcosphere(1.0, 3)};
  std::vector<double> expected[2];
  for (int m = 0; m < 2; ++m) {
    const std::string id = "m" + std::to_string(m);
    ASSERT_TRUE(memory_->client->Upload(meshes[m], id).ok());
    expected[m] = memory_->client->ComputeSdf(id, SdfParams{})->result.values;
  }
  Replica c(a_->options);
  ASSERT_TRUE(a_->client->Upload(meshes[0], "s1").ok());
  std::atomic<bool> done{false};
  std::atomic<int> checked{0}, updated{0}, bad{0};
  std::thread churn([&] {
    for (int k = 1; k <= 150; ++k) {
      (void)a_->client->Delete("s1");
      (void)a_->client->Upload(meshes[k % 2], "s1");
    }
    done = true;
  });
  auto reader = [&](Replica& r) {
    while (!done) {
      auto got =
          r.client->ComputeSdf("s1", SdfParams{}, {.expected_generation = 0});
      if (got.ok()) {
        const auto& v = got->result.values;
        const int m = std::ssize(v) == meshes[0].num_vertices() ? 0 : 1;
        if (!SameBits(v, expected[m])) ++bad;
        ++checked;
      } else if (got.status().code() != absl::StatusCode::kNotFound &&
                 got.status().code() != absl::StatusCode::kAborted) {
        ADD_FAILURE() << got.status();
        ++bad;
      }
    }
  };
  auto writer = [&](Replica& r) {
    int k = 0;
    while (!done) {
      const Mesh& m = meshes[k++ % 2];
      auto u = r.client->UpdatePositions("s1", 0, 3, m.positions);
      if (u.ok()) {
        ++updated;
        continue;
      }
      const auto code = u.status().code();
      if (code != absl::StatusCode::kNotFound &&
          code != absl::StatusCode::kAborted &&
          code != absl::StatusCode::kInvalidArgument) {
        ADD_FAILURE() << u.status();
        ++bad;
      }
    }
  };
  std::thread r1([&] { reader(*b_); }), r2([&] { reader(c); });
  std::thread w([&] { writer(c); });
  churn.join();
  r1.join();
  r2.join();
  w.join();
  EXPECT_EQ(bad, 0);
  EXPECT_GT(checked, 0);
  std::printf("races: %d replies checked, %d updates applied\n", checked.load(),
              updated.load());
  // Whatever the last incarnation is, every replica reads it intact.
  for (Replica* r : {a_.get(), b_.get(), &c}) {
    auto info = r->client->Get("s1");
    ASSERT_TRUE(info.ok()) << info.status();
    auto sdf = r->client->ComputeSdf("s1", SdfParams{});
    ASSERT_TRUE(sdf.ok()) << sdf.status();
    EXPECT_EQ(std::ssize(sdf->result.values), info->num_vertices);
  }
}

// A claim lives twice --upload_idle_seconds unless a message renews it: a
// slow but live upload keeps its slot past that, on every replica.
TEST_F(RedisStoreTest, ALiveUploadRenewsItsClaim) {
  server::ServerOptions o;
  o.max_sessions_per_tenant = 1;
  o.upload_idle_seconds = 0.4;  // claims live 0.8 s unless renewed.
  o.upload_min_bytes_per_second = 0;
  Start(o);
  grpc::ClientContext ctx;
  v1::CreateSessionResponse resp;
  auto w = b_->client->stub().CreateSession(&ctx, &resp);
  ASSERT_TRUE(w->Write(UploadHeader(1000, 1000)));
  // Empty chunks: the upload is alive but buffers nothing more.
  v1::CreateSessionRequest empty;
  empty.mutable_chunk();
  for (int i = 0; i < 10; ++i) {  // 2 s of messages every 0.2 s.
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    ASSERT_TRUE(w->Write(empty));
  }
  auto refused = a_->client->Upload(Knight(), "late");
  EXPECT_EQ(Code(refused), absl::StatusCode::kResourceExhausted);
  ctx.TryCancel();
  w->Finish();
}

// A record whose facts and mesh disagree (a 2D session with triangles) is
// DATA_LOSS when loaded, never a session.
TEST_F(RedisStoreTest, ARecordWhoseFactsAndMeshDisagreeIsDataLoss) {
  server::RedisRecords records(RecordsOptions());
  server::SessionRecord rec = SmallRecord("odd", "one");
  rec.info.dimension = 2;
  ASSERT_TRUE(records.Create("", rec, kRoomy, "").ok());
  EXPECT_EQ(records.Load("", "odd").status().code(),
            absl::StatusCode::kDataLoss);
}

// A creation retried after its reply was lost (same incarnation) succeeds
// again instead of leaving an orphan; another incarnation is ALREADY_EXISTS.
TEST_F(RedisStoreTest, RetriedCreateIsIdempotent) {
  server::RedisRecords records(RecordsOptions());
  server::SessionRecord rec = SmallRecord("again", "one");
  ASSERT_TRUE(records.Create("", rec, kRoomy, "").ok());
  EXPECT_TRUE(records.Create("", rec, kRoomy, "").ok());
  rec.incarnation = "two";
  EXPECT_EQ(records.Create("", rec, kRoomy, "").code(),
            absl::StatusCode::kAlreadyExists);
}

TEST_F(RedisStoreTest, IdleTtlIsGlobalAndSlides) {
  server::ServerOptions o;
  o.session_ttl_seconds = 1.5;
  Start(o);
  const Mesh mesh = Knight();
  ASSERT_TRUE(a_->client->Upload(mesh, "ttl").ok());
  for (int i = 0; i < 3; ++i) {  // used every 0.6 s: stays.
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    ASSERT_TRUE((i % 2 ? a_ : b_)->client->ComputeSdf("ttl", SdfParams{}).ok());
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1800));
  EXPECT_EQ(Code(a_->client->ComputeSdf("ttl", SdfParams{})),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(Code(b_->client->Get("ttl")), absl::StatusCode::kNotFound);
  EXPECT_TRUE(a_->client->List()->empty());
}

TEST_F(RedisStoreTest, RedisDownIsUnavailableAndSessionsSurviveItsRestart) {
  const Mesh mesh = Knight();
  ASSERT_TRUE(a_->client->Upload(mesh, "durable").ok());
  ASSERT_TRUE(
      a_->client->UpdatePositions("durable", 0, 3, Moved(mesh, 1)).ok());
  redis_.Stop(SIGKILL);
  auto down = b_->client->ComputeSdf("durable", SdfParams{});
  EXPECT_EQ(Code(down), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(down.status().message()),
              HasSubstr(redis_.url().substr(8)));
  EXPECT_EQ(Code(a_->client->Upload(mesh, "new")),
            absl::StatusCode::kUnavailable);
  EXPECT_THAT(b_->metrics.Text(),
              Not(HasSubstr("meshgauge_session_store_errors_total 0")));
  redis_.Start();  // same port and AOF directory.
  auto back = b_->client->ComputeSdf("durable", SdfParams{},
                                     {.expected_generation = 1});
  ASSERT_TRUE(back.ok()) << back.status();
  auto again = a_->client->ComputeSdf("durable", SdfParams{},
                                      {.expected_generation = 1});
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_TRUE(SameBits(back->result.values, again->result.values));
}

TEST_F(RedisStoreTest, ClientRidesOutAReplicaRestart) {
  const Mesh mesh = Knight();
  server::ServerOptions o = a_->options;
  const int port = testing::FreePort();
  auto replica = std::make_unique<Replica>(o, port);
  client::RemoteClient c("127.0.0.1:" + std::to_string(port));
  ASSERT_TRUE(c.Upload(mesh, "restart").ok());
  auto before = c.ComputeSdf("restart", SdfParams{});
  ASSERT_TRUE(before.ok());
  replica.reset();        // the replica goes away...
  std::thread back([&] {  // ...and a new one takes its place 0.5 s later.
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    replica = std::make_unique<Replica>(o, port);
  });
  // The client waits for the channel and retries; the session is in Redis.
  auto after = c.ComputeSdf("restart", SdfParams{});
  back.join();
  ASSERT_TRUE(after.ok()) << after.status();
  EXPECT_TRUE(SameBits(before->result.values, after->result.values));
}

// In a rolling upgrade, replicas of two record formats share one Redis.
// Every key carries the format, so a replica never reads (DATA_LOSS) nor
// lists another format's records: here a record of this format renamed to
// another format's keys, and a record left by a release before formats were
// in the keys (hand-written bytes under the bare prefix).
TEST_F(RedisStoreTest, ARecordOfAnotherFormatIsNeverRead) {
  ASSERT_TRUE(a_->client->Upload(Knight(), "k").ok());
  const std::string current = absl::StrCat("mg:r", server::kRecordFormat, ":");
  const std::vector<std::string> keys = redis_.Command({"KEYS", "*"});
  ASSERT_FALSE(keys.empty());
  for (const std::string& key : keys) {
    ASSERT_TRUE(key.starts_with(current)) << key;
    const std::string rest = key.substr(current.size());
    redis_.Command({"COPY", key, "mg:" + rest});  // the bare layout.
    redis_.Command({"RENAME", key, absl::StrCat("mg:r", 1000, ":", rest)});
  }
  for (const std::string& key : redis_.Command({"KEYS", "mg:t*:s:k"})) {
    redis_.Command({"HSET", key, "info", std::string("\3\0\0\0\xff", 5)});
  }
  EXPECT_EQ(Code(b_->client->Get("k")), absl::StatusCode::kNotFound);
  EXPECT_EQ(Code(b_->client->ComputeSdf("k", SdfParams{})),
            absl::StatusCode::kNotFound);
  auto listed = b_->client->List();
  ASSERT_TRUE(listed.ok()) << listed.status();
  EXPECT_TRUE(listed->empty());
  EXPECT_TRUE(b_->client->Upload(Knight(), "k").ok());
}

TEST_F(RedisStoreTest, MalformedStoreUrlIsRejectedAtStart) {
  server::ServerOptions o;
  o.address = "127.0.0.1:0";
  o.metrics_address = "";
  for (const char* url : {"redis:/x", "http://h:1", "redis://h:0",
                          "redis://h:99999", "redis://"}) {
    o.session_store = url;
    server::Metrics m;
    server::SteadyClock c;
    auto s = server::MeshGaugeServer::Start(o, &m, &c);
    EXPECT_EQ(Code(s), absl::StatusCode::kInvalidArgument) << url;
  }
}

TEST(RecordConvertTest, RoundTripsExactly) {
  Mesh mesh = Knight();
  mesh.face_regions.assign(mesh.num_faces(), 0);
  mesh.face_regions[5] = 7;
  mesh.region_directions[7] = ConeDirection::kOutward;
  mesh.region_directions[0] = ConeDirection::kInward;
  mesh.positions[0].x = 0.1 + 1e-17;  // not a float32 value.
  const wire::SessionInfo info{.session_id = "x",
                               .dimension = 3,
                               .num_vertices = 502,
                               .num_faces = mesh.num_faces(),
                               .generation = 7,
                               .memory_bytes = 99,
                               .signed_volume = -2.5,
                               .closed = true,
                               .warnings = {"w1", "w2"}};
  auto decoded = server::DecodeInfo(server::EncodeInfo(info));
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  const wire::SessionInfo& info2 = *decoded;
  EXPECT_EQ(info2.session_id, "");  // kept apart by the store.
  EXPECT_EQ(info2.generation, 0);
  EXPECT_EQ(info2.dimension, 3);
  EXPECT_EQ(info2.num_vertices, 502);
  EXPECT_EQ(info2.num_faces, mesh.num_faces());
  EXPECT_EQ(info2.memory_bytes, 99);
  EXPECT_EQ(info2.signed_volume, -2.5);
  EXPECT_TRUE(info2.closed);
  EXPECT_EQ(info2.warnings, info.warnings);
  Mesh topo;
  ASSERT_TRUE(
      server::DecodeTopology(server::EncodeTopology(mesh), 502, &topo).ok());
  EXPECT_EQ(topo.dimension, 3);
  ASSERT_EQ(topo.num_faces(), mesh.num_faces());
  for (int64_t f = 0; f < mesh.num_faces(); ++f) {
    EXPECT_EQ(topo.faces[f].size, mesh.faces[f].size);
    EXPECT_EQ(topo.faces[f].v, mesh.faces[f].v);
  }
  EXPECT_EQ(topo.face_regions, mesh.face_regions);
  EXPECT_EQ(topo.region_directions, mesh.region_directions);
  auto p =
      server::DecodePositions(server::EncodePositions(mesh.positions), 502);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(std::memcmp(p->data(), mesh.positions.data(), 502 * sizeof(Vec3)),
            0);
  // A newer replica's added field is skipped (rolling upgrades): field 99,
  // varint 1.
  const std::string added("\x98\x06\x01", 3);
  decoded = server::DecodeInfo(server::EncodeInfo(info) + added);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(decoded->warnings, info.warnings);
  ASSERT_TRUE(
      server::DecodeTopology(server::EncodeTopology(mesh) + added, 502, &topo)
          .ok());
  EXPECT_EQ(topo.face_regions, mesh.face_regions);
}

// Corrupt records: DATA_LOSS, never a crash (and never a mesh whose faces
// index past its vertices).
TEST(RecordConvertTest, CorruptBytesAreDataLoss) {
  const Mesh mesh = MakeIcosphere(1.0, 1);
  const int64_t nv = mesh.num_vertices();
  const std::string t = server::EncodeTopology(mesh);
  for (size_t n = 1; n < t.size(); ++n) {  // no cut leaves whole faces.
    Mesh out;
    EXPECT_EQ(server::DecodeTopology(t.substr(0, n), nv, &out).code(),
              absl::StatusCode::kDataLoss)
        << n;
  }
  Mesh out;
  EXPECT_EQ(server::DecodeTopology(t, nv - 1, &out).code(),
            absl::StatusCode::kDataLoss);  // an index out of range.
  Mesh quads = mesh;
  quads.dimension = 2;  // triangles in 2D.
  EXPECT_EQ(
      server::DecodeTopology(server::EncodeTopology(quads), nv, &out).code(),
      absl::StatusCode::kDataLoss);
  Mesh regions = mesh;
  regions.face_regions.assign(3, 0);  // not one per face.
  EXPECT_EQ(
      server::DecodeTopology(server::EncodeTopology(regions), nv, &out).code(),
      absl::StatusCode::kDataLoss);
  const std::string p = server::EncodePositions(mesh.positions);
  for (size_t n = 0; n < p.size(); n += 7) {
    EXPECT_EQ(server::DecodePositions(p.substr(0, n), nv).status().code(),
              absl::StatusCode::kDataLoss);
  }
  EXPECT_EQ(server::DecodePositions(p, nv + 1).status().code(),
            absl::StatusCode::kDataLoss);
  // A forged count whose triple wraps around to the doubles present.
  const std::string two_doubles =
      std::string("\x0a\x10", 2) + std::string(16, '\0');
  EXPECT_EQ(
      server::DecodePositions(two_doubles, 0x5555555555555556).status().code(),
      absl::StatusCode::kDataLoss);
  wire::SessionInfo huge;
  huge.num_vertices = 1ll << 40;
  huge.num_faces = 1;
  EXPECT_EQ(server::DecodeInfo(server::EncodeInfo(huge)).status().code(),
            absl::StatusCode::kDataLoss);
  for (const std::string& bad : {std::string("\xff\xff"), std::string()}) {
    EXPECT_EQ(server::DecodeInfo(bad).status().code(),
              absl::StatusCode::kDataLoss);
  }
}

}  // namespace
}  // namespace meshgauge
