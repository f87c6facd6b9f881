// `meshgauge remote VERB` against `meshgauge VERB`: every verb computing on
// a mesh, run here and through an in-process server on the same mesh, must
// write the same stdout (text and --json, timings aside) and the same files
// (--csv, --ply, --vjp, --jacobian, --grad), byte for byte.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/cli/backend.h"
#include "lib/io/mesh_io.h"
#include "tests/cli_test_util.h"
#include "tests/server_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Slurp;
using testing::CliRun;
using ::testing::HasSubstr;
using testing::RunCli;
using testing::RunCliStderr;
using testing::SharedMesh;
using testing::Tmp;

// A summary without what measures time or this process's memory: the keys
// seconds, rays_per_second, stage_seconds and memory_bytes.
void EraseTimes(nlohmann::json& summary) {
  summary.erase("seconds");
  summary.erase("rays_per_second");
  summary.erase("stage_seconds");
  summary.erase("memory_bytes");
}

// stdout without what measures time or memory: EraseTimes, the text
// summary's "rays: N in T s (R rays/s)", "time: ..." and "memory: ..." lines.
std::string Untimed(const std::string& out) {
  if (!out.empty() && out[0] == '{') {
    nlohmann::json j = nlohmann::json::parse(out);
    EraseTimes(j);
    return j.dump();
  }
  std::vector<std::string> lines;
  for (absl::string_view line : absl::StrSplit(out, '\n')) {
    if (!absl::StartsWith(line, "rays: ") &&
        !absl::StartsWith(line, "time: ") &&
        !absl::StartsWith(line, "memory: ")) {
      lines.emplace_back(line);
    }
  }
  return absl::StrJoin(lines, "\n");
}

class CliRemoteTest : public testing::ServerFixture {
 protected:
  // Runs `VERB MESH ARGS` here and `remote VERB MESH ARGS` on the server,
  // each writing the files named in `files` (flag name -> path suffix), and
  // expects identical outputs (`remote_args` go to the remote verb only).
  // Returns the local stdout.
  std::string ExpectSameOutputs(const std::string& verb,
                                const std::string& mesh,
                                const std::string& args,
                                const std::vector<std::string>& file_flags,
                                const std::string& remote_args = "") {
    std::string local_files, remote_files;
    for (const std::string& flag : file_flags) {
      absl::StrAppend(&local_files, " --", flag, " ", Tmp("local." + flag));
      absl::StrAppend(&remote_files, " --", flag, " ", Tmp("remote." + flag));
    }
    const auto local =
        RunCli(verb + " " + mesh + " " + args + local_files, false);
    const auto remote = RunCli("remote " + verb + " " + mesh + " " + args +
                                   remote_args + remote_files + " --server " +
                                   target_,
                               false);
    EXPECT_EQ(local.exit_code, 0) << verb << " " << args;
    EXPECT_EQ(remote.exit_code, 0) << "remote " << verb << " " << args;
    EXPECT_EQ(Untimed(remote.out), Untimed(local.out)) << verb << " " << args;
    for (const std::string& flag : file_flags) {
      const std::string here = Slurp(Tmp("local." + flag));
      EXPECT_FALSE(here.empty()) << "--" << flag;
      EXPECT_TRUE(here == Slurp(Tmp("remote." + flag)))
          << verb << " --" << flag << " differs";
      std::remove(Tmp("local." + flag).c_str());
      std::remove(Tmp("remote." + flag).c_str());
    }
    return local.out;
  }
};

// The server streams the pass's progress only when asked: the bar names the
// work and ends at 100 %; without the bar nothing is drawn.
TEST_F(CliRemoteTest, TheServerStreamsProgressWhenTheBarIsDrawn) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const std::string args = " --rays 30 --server " + target_;
  const CliRun drawn =
      RunCliStderr("remote sdf " + knight + args + " --progress always");
  EXPECT_EQ(drawn.exit_code, 0) << drawn.out;
  EXPECT_THAT(drawn.out, HasSubstr("tracing 15060 rays on the server ["));
  EXPECT_THAT(drawn.out, HasSubstr("100%"));
  const CliRun quiet =
      RunCliStderr("remote sdf " + knight + args + " --progress never");
  EXPECT_EQ(quiet.exit_code, 0) << quiet.out;
  EXPECT_EQ(quiet.out, "");
}

TEST_F(CliRemoteTest, SdfSummaryJsonCsvAndPlyAreTheLocalOnes) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const std::string text =
      ExpectSameOutputs("sdf", knight, "--rays 30", {"csv", "ply"});
  EXPECT_THAT(text, HasSubstr("502 ok"));
  ExpectSameOutputs("sdf", knight, "--rays 30 --json", {"csv"});
  ExpectSameOutputs("sdf", knight, "--method normal --json", {"csv"});
  // The inscribed ball and the opposite points of every method.
  ExpectSameOutputs("sdf", knight, "--method sphere --opposite --json",
                    {"csv"});
  ExpectSameOutputs("sdf", knight, "--method sphere --contact-angle 45",
                    {"csv"});
  ExpectSameOutputs("sdf", knight, "--rays 30 --opposite", {"csv"});
  // Face samples (SPEC v2 §5c), their PLY and segments.
  ExpectSameOutputs("sdf", knight, "--rays 30 --samples faces --json",
                    {"csv", "ply", "opposite-ply"});
  ExpectSameOutputs("sdf", knight, "--method sphere --samples faces", {"csv"});
  ExpectSameOutputs("sdf", knight,
                    "--cone-angle 60 --kappa 0.5 --normals angle", {"csv"});
  // Missing values and warnings: the inward horse, few rays.
  ExpectSameOutputs("sdf", SharedMesh("horse.ply"), "--rays 4 --json", {"csv"});
  // 2D, with a region's cone turned outward.
  const std::string hollow = Tmp("hollow.obj");
  ASSERT_EQ(
      RunCli("shape hollow --radius 1 --size 0.05 --out " + hollow).exit_code,
      0);
  ExpectSameOutputs("sdf", hollow, "--region-direction 1=outward --json",
                    {"csv", "ply"});
  std::remove(hollow.c_str());
}

TEST_F(CliRemoteTest, GradVjpAndJacobianAreTheLocalOnes) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const std::string weights = Tmp("weights.txt");
  {
    std::ofstream w(weights);
    for (int i = 0; i < 502; ++i) w << std::sin(0.3 * i) << "\n";
  }
  ExpectSameOutputs("grad", knight, "--rays 20", {"vjp", "jacobian"});
  ExpectSameOutputs("grad", knight, "--method sphere", {"vjp", "jacobian"});
  ExpectSameOutputs("grad", knight, "--rays 20 --json --weights " + weights,
                    {"vjp"});
  {
    std::ofstream w(weights);
    for (int i = 0; i < 1000; ++i) w << std::sin(0.3 * i) << "\n";
  }
  ExpectSameOutputs("grad", knight,
                    "--rays 20 --samples faces --weights " + weights,
                    {"vjp", "jacobian"});
  std::remove(weights.c_str());
}

// --fan-out K: the pass and the VJP split into K ranges, the same files.
TEST_F(CliRemoteTest, FannedOutSdfAndGradAreTheLocalOnes) {
  const std::string knight = SharedMesh("decimated-knight.off");
  ExpectSameOutputs("sdf", knight, "--rays 20 --json", {"csv", "ply"},
                    " --fan-out 3");
  ExpectSameOutputs("grad", knight, "--rays 20", {"vjp", "jacobian"},
                    " --fan-out 4");
  ExpectSameOutputs("grad", knight, "--rays 20 --samples faces", {"vjp"},
                    " --fan-out 2");
}

TEST_F(CliRemoteTest, PenaltyAndConstraintAreTheLocalOnes) {
  const std::string knight = SharedMesh("decimated-knight.off");
  ExpectSameOutputs("penalty", knight, "--t-min 0.3 --rays 20", {"grad"});
  ExpectSameOutputs("penalty", knight,
                    "--t-min 0.3 --form ks --rho 30 --json --rays 20",
                    {"grad"});
  ExpectSameOutputs("penalty", knight, "--t-min 0.3 --form thesis --power 3",
                    {});
  ExpectSameOutputs("penalty", knight,
                    "--method sphere --t-min 0.05 --form ks --json", {"grad"});
}

// The server runs the probes (GradCheck): the same table, counts and
// verdict; its own limits are the server's errors.
TEST_F(CliRemoteTest, GradcheckIsTheLocalOne) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const std::string text =
      ExpectSameOutputs("gradcheck", knight, "--rays 20 --samples 4", {});
  EXPECT_THAT(text, HasSubstr("verdict: PASS"));
  ExpectSameOutputs("gradcheck", knight,
                    "--rays 20 --samples 3 --t-min 0.3 --form ks --json", {});
  EXPECT_THAT(ExpectSameOutputs("gradcheck", knight,
                                "--rays 20 --samples faces --probes 3", {}),
              HasSubstr("verdict: PASS"));
  const CliRun refused = RunCliStderr("remote gradcheck " + knight +
                                      " --samples 1001 --server " + target_);
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.out, HasSubstr("samples must be in [1, 1000]"));
}

TEST_F(CliRemoteTest, CalibrateIsTheLocalOne) {
  const std::string knight = SharedMesh("decimated-knight.off");
  ExpectSameOutputs("calibrate", knight, "--t-min 0.2 --rays 20", {});
  ExpectSameOutputs("calibrate", knight, "--t-min 0.2 --bins 7 --json", {});
}

TEST_F(CliRemoteTest, ReportIsTheLocalOne) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const std::string args = " --t-min 0.1 --rays 20 --view-size 120 100 --out ";
  const auto local = RunCli("report " + knight + args + Tmp("local_report"));
  const auto remote = RunCli("remote report " + knight + args +
                             Tmp("remote_report") + " --server " + target_);
  ASSERT_EQ(local.exit_code, 0) << local.out;
  ASSERT_EQ(remote.exit_code, 0) << remote.out;
  EXPECT_EQ(remote.out, local.out);
  for (const char* file : {"views.png", "histogram.png", "colored.ply"}) {
    const std::string here = Slurp(Tmp("local_report/") + file);
    EXPECT_FALSE(here.empty()) << file;
    EXPECT_TRUE(here == Slurp(Tmp("remote_report/") + file)) << file;
  }
  // report.json: every number but the timings, bit for bit.
  auto untimed = [](const std::string& dir) {
    auto j = nlohmann::json::parse(Slurp(Tmp(dir + "/report.json")));
    j.erase("timing");
    EraseTimes(j["summary"]);
    return j;
  };
  EXPECT_EQ(untimed("local_report").dump(), untimed("remote_report").dump());
  EXPECT_TRUE(untimed("remote_report").contains("bands"));
  // index.html: the interactive view's data (the mesh, its values, the
  // regions) is the local page's.
  auto view_data = [](const std::string& dir) {
    const std::string page = Slurp(Tmp(dir + "/index.html"));
    const std::string open = "<script id=\"mg-data\" type=\"application/json\">";
    const size_t begin = page.find(open);
    if (begin == std::string::npos) return std::string();
    const size_t end = page.find("</script>", begin);
    return page.substr(begin + open.size(), end - begin - open.size());
  };
  EXPECT_FALSE(view_data("remote_report").empty());
  EXPECT_TRUE(view_data("local_report") == view_data("remote_report"));
  std::filesystem::remove_all(Tmp("local_report"));
  std::filesystem::remove_all(Tmp("remote_report"));
}

TEST_F(CliRemoteTest, TemporarySessionsAreDeletedNamedOnesKeptAndChecked) {
  const std::string knight = SharedMesh("decimated-knight.off");
  ExpectSameOutputs("sdf", knight, "--rays 10", {});
  EXPECT_EQ(client_->List()->size(), 0u) << "the temporary session is gone";
  const std::string on = " --session-id kept --server " + target_;
  ASSERT_EQ(RunCli("remote sdf " + knight + " --rays 10" + on).exit_code, 0);
  auto info = client_->Get("kept");
  ASSERT_TRUE(info.ok()) << info.status();
  // Used again, not re-uploaded: the session's cached pass serves the VJP.
  // (The connection flags may also come before the verb.)
  ASSERT_EQ(RunCli("remote --server " + target_ + " grad " + knight +
                   " --rays 10 --session-id kept")
                .exit_code,
            0);
  EXPECT_THAT(
      metrics_.Text(),
      HasSubstr("meshgauge_hit_cache_requests_total{result=\"reused\"} 1"));
  // Another mesh under that id is refused.
  const auto other =
      RunCli("remote sdf " + SharedMesh("spot_triangulated.obj") + on);
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_THAT(other.out, HasSubstr("not the given mesh"));
}

// A remote backend asks for the VJP and the penalty at its pass's
// generation: a session another client moved after the pass is ABORTED,
// not answered for the new positions (with and without a fan-out).
TEST_F(CliRemoteTest, ASessionMovedAfterThePassIsAbortedNotAnswered) {
  const absl::StatusOr<Mesh> mesh =
      ReadMesh(SharedMesh("decimated-knight.off"));
  ASSERT_TRUE(mesh.ok()) << mesh.status();
  for (const int fan_out : {1, 2}) {
    const std::string id = "moved" + std::to_string(fan_out);
    cli::RemoteFlags flags;
    flags.server = target_;
    auto make =
        cli::RemoteBackend(flags, id, cli::ProgressMode::kNever, fan_out);
    ASSERT_TRUE(make.ok()) << make.status();
    auto backend = (*make)(*mesh);
    ASSERT_TRUE(backend.ok()) << backend.status();
    SdfParams params;
    params.rays = 10;
    auto pass = (*backend)->Sdf(params, cli::Derivatives::kVjp);
    ASSERT_TRUE(pass.ok()) << pass.status();
    const std::vector<double> ones(mesh->num_vertices(), 1.0);
    ASSERT_TRUE((*backend)->Vjp(ones).ok()) << "before the move";
    auto info = client_->Get(id);
    ASSERT_TRUE(info.ok()) << info.status();
    std::vector<Vec3> moved = mesh->positions;
    moved[0] = moved[0] * 1.001;
    ASSERT_TRUE(
        client_->UpdatePositions(id, info->generation, 3, {moved[0]}, {0})
            .ok());
    EXPECT_EQ((*backend)->Vjp(ones).status().code(), absl::StatusCode::kAborted)
        << "fan-out " << fan_out;
    PenaltyParams penalty;
    penalty.t_min = 0.1;
    EXPECT_EQ((*backend)->Penalty(*pass, penalty, true).status().code(),
              absl::StatusCode::kAborted)
        << "fan-out " << fan_out;
  }
}

// remote server-info prints GetServerInfo: the release and the limits the
// caller's tenant meets, here set apart from their defaults.
TEST_F(CliRemoteTest, ServerInfoPrintsTheLimitsTheCallerMeets) {
  server::ServerOptions o;
  o.max_rays = 77;
  o.max_vertices = 123456;
  o.max_faces = 234567;
  o.max_sessions = 9;
  o.max_sessions_per_tenant = 5;
  o.memory_budget_bytes_per_tenant = 3 << 20;
  RestartServer(o);
  const auto got = RunCli("remote server-info --json --server " + target_);
  ASSERT_EQ(got.exit_code, 0) << got.out;
  const nlohmann::json j = nlohmann::json::parse(got.out);
  EXPECT_THAT(j["version"].get<std::string>(),
              ::testing::MatchesRegex("[0-9]+\\.[0-9]+\\.[0-9]+"));
  EXPECT_EQ(j["api"], "meshgauge.v1");
  EXPECT_EQ(j["max_rays"], 77);
  EXPECT_EQ(j["max_vertices"], 123456);
  EXPECT_EQ(j["max_faces"], 234567);
  EXPECT_EQ(j["max_sessions"], 5);
  EXPECT_EQ(j["memory_budget_bytes"], 3 << 20);
  EXPECT_EQ(j["max_message_bytes"], options_.max_message_bytes);
  EXPECT_EQ(j["max_upload_message_bytes"], options_.max_upload_message_bytes);
  EXPECT_GT(j["max_upload_file_bytes"], 0);
  EXPECT_LE(j["max_upload_file_bytes"], 3 << 20);
  const auto text = RunCli("remote server-info --server " + target_);
  EXPECT_THAT(text.out, HasSubstr("max_rays: 77\n"));
}

}  // namespace
}  // namespace meshgauge
