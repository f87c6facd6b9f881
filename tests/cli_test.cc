// The meshgauge CLI end to end: summary, JSON keys, CSV and PLY outputs,
// precise errors with non-zero exit status.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "absl/strings/str_split.h"
#include "lib/core/shapes.h"
#include "lib/core/vec3.h"
#include "lib/embree/cone_walk.h"
#include "lib/io/mesh_io.h"
#include "lib/io/png_file.h"
#include "tests/cli_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Slurp;
using testing::CliRun;
using ::testing::HasSubstr;
using ::testing::Not;
using testing::RunCli;
using testing::RunCliStderr;
using testing::SharedMesh;
using testing::Tmp;

// An unwelded export (a cube of six grids, every edge a seam): without
// --weld each of the 150 vertices is measured on its own, the seams' copies
// along their own grid's normal; --weld merges the seams into 98 vertices,
// every one gets a value, and the CSV keeps the file's 150 rows with each
// seam copy carrying its welded vertex's value.
TEST(CliTest, WeldMeasuresAnUnweldedCubeAndKeepsTheFilesRows) {
  const std::string obj = Tmp("six_grids.obj");
  ASSERT_TRUE(WriteObj(obj, testing::SixGridCube()).ok());
  const CliRun raw = RunCli("sdf " + obj + " --method normal --json");
  ASSERT_EQ(raw.exit_code, 0) << raw.out;
  EXPECT_EQ(nlohmann::json::parse(raw.out)["vertices"], 150);
  // Every seam copy's normal ray meets the far face: the cone walk meets
  // it where Embree's box test missed it for 54 of them
  // (ConeWalkTest.MeetsTheFarFaceAlongASeam...).
  EXPECT_EQ(nlohmann::json::parse(raw.out)["no_hit"],
            ConeWalk::Supported() ? 0 : 54);
  const std::string csv = Tmp("six_grids.csv");
  // --weld before the mesh takes no value: give TOL as --weld=TOL there.
  const CliRun welded =
      RunCli("sdf --weld " + obj + " --method normal --json --csv " + csv);
  EXPECT_NE(welded.exit_code, 0);
  EXPECT_THAT(welded.out, HasSubstr("--weld=TOL"));
  const CliRun ok =
      RunCli("sdf " + obj + " --method normal --json --weld --csv " + csv);
  ASSERT_EQ(ok.exit_code, 0) << ok.out;
  const auto j = nlohmann::json::parse(ok.out);
  EXPECT_EQ(j["vertices"], 98);
  EXPECT_EQ(j["ok"], 98);
  EXPECT_THAT(j["warnings"][0].get<std::string>(),
              HasSubstr("52 vertices welded"));
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  std::map<std::string, std::string> value_at;  // position -> value
  int rows = 0;
  while (std::getline(in, line)) {
    const std::vector<std::string> cells = absl::StrSplit(line, ',');
    ASSERT_GE(cells.size(), 5u);
    EXPECT_EQ(cells[0], std::to_string(rows));
    ASSERT_FALSE(cells[4].empty()) << line;
    const std::string at = cells[1] + " " + cells[2] + " " + cells[3];
    auto [it, added] = value_at.try_emplace(at, cells[4]);
    EXPECT_EQ(it->second, cells[4]) << at;  // seam copies agree.
    ++rows;
  }
  EXPECT_EQ(rows, 150);
  EXPECT_EQ(value_at.size(), 98u);
  const CliRun tol = RunCli("sdf " + obj + " --method normal --weld=1e-6");
  EXPECT_EQ(tol.exit_code, 0) << tol.out;
  const CliRun bad = RunCli("sdf " + obj + " --weld=0.5");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.out, HasSubstr("weld tolerance"));
}

// A mesh far below the ray tracer's scale gets no value: sdf says why and
// fails, as grad, penalty and report do on unmeasurable surfaces.
TEST(CliTest, ATinyMeshFailsNamingItsScale) {
  Mesh tiny = MakeIcosphere(1, 2);
  for (Vec3& p : tiny.positions) p *= 1e-17;
  const std::string obj = Tmp("tiny_sphere.obj");
  ASSERT_TRUE(WriteObj(obj, tiny).ok());
  const CliRun r = RunCli("sdf " + obj);
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("warning: the mesh is tiny: it is 2e-17 across"));
  EXPECT_THAT(r.out, HasSubstr("error: no vertex has a value: the mesh is tiny"));
  EXPECT_THAT(r.out, HasSubstr("scale the mesh up"));
}

TEST(CliTest, JsonSummaryHasAllKeys) {
  const CliRun r =
      RunCli("sdf " + SharedMesh("decimated-knight.off") + " --json --rays 20");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key :
       {"vertices", "faces", "dimension", "ok", "no_hit", "no_faces", "sdf_min",
        "sdf_median", "sdf_max", "sdf_mean", "integral", "rays", "seconds",
        "rays_per_second"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["vertices"], 502);
  EXPECT_EQ(j["ok"], 502);
  EXPECT_EQ(j["rays"], 502 * 20);
  EXPECT_GT(j["integral"].get<double>(), 0);
  for (const char* stage : {"read", "checks", "setup", "rays"}) {
    EXPECT_GE(j["stage_seconds"][stage].get<double>(), 0) << stage;
  }
}

// --progress always draws on any stderr, naming the work up front; the
// default draws only on a terminal, so here nothing.
TEST(CliTest, ProgressBarsNameTheWorkAndEndAtOneHundredPercent) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const CliRun sdf =
      RunCliStderr("sdf " + knight + " --rays 20 --progress always");
  EXPECT_EQ(sdf.exit_code, 0) << sdf.out;
  EXPECT_THAT(sdf.out, HasSubstr("tracing 10040 rays ["));
  EXPECT_THAT(sdf.out, HasSubstr("100%"));
  const CliRun grad = RunCliStderr("grad " + knight + " --rays 20 --vjp " +
                                   Tmp("p.csv") + " --progress always");
  EXPECT_THAT(grad.out, HasSubstr("derivatives (g^T J) ["));
  // 1 + 2 x 3 x 2 passes, reported as one bar.
  const CliRun check = RunCliStderr("gradcheck " + knight +
                                    " --rays 8 --samples 2 --progress always");
  EXPECT_THAT(check.out, HasSubstr("gradcheck: 13 passes of 4016 rays ["));
  EXPECT_THAT(check.out, HasSubstr("100%"));
  EXPECT_EQ(check.out.find("100%"), check.out.rfind("100%")) << check.out;
  const CliRun quiet = RunCliStderr("sdf " + knight + " --rays 20");
  EXPECT_EQ(quiet.out, "");
  std::remove(Tmp("p.csv").c_str());
}

TEST(CliTest, ValuesAloneKeepNoHitTableAndMemoryIsReported) {
  const CliRun r =
      RunCli("sdf " + SharedMesh("decimated-knight.off") + " --json --rays 20");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto m = nlohmann::json::parse(r.out)["memory_bytes"];
  // 502 positions and 1000 faces at least; a BVH; no table of 10,040 rays.
  EXPECT_GE(m["mesh"].get<int64_t>(), 502 * 24 + 1000 * 20);
  EXPECT_GT(m["derived"].get<int64_t>(), 0);
  EXPECT_GT(m["bvh"].get<int64_t>(), 1000 * 16);
  EXPECT_EQ(m["hit_table"].get<int64_t>(), 0);
  EXPECT_GT(m["peak_rss"].get<int64_t>(), m["mesh"].get<int64_t>());
}

TEST(CliTest, WritesCsvAndPly) {
  const std::string csv = Tmp("k.csv"), ply = Tmp("k.ply");
  const CliRun r = RunCli("sdf " + SharedMesh("decimated-knight.off") +
                          " --rays 10 --csv " + csv + " --ply " + ply);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("502 ok"));
  std::ifstream in(csv);
  std::string header, first;
  std::getline(in, header);
  std::getline(in, first);
  EXPECT_EQ(header, "vertex,x,y,z,sdf,normalized,hits,kept,status");
  EXPECT_THAT(first, HasSubstr(",OK"));
  int lines = 2;
  for (std::string l; std::getline(in, l);) ++lines;
  EXPECT_EQ(lines, 503);
  EXPECT_GT(std::filesystem::file_size(ply), 502u * 16);
  std::filesystem::remove(csv);
  std::filesystem::remove(ply);
}

// --method sphere --opposite: the touching point of each vertex's ball is
// at distance `value` / 2 from the ball's centre, so its distance to the
// vertex is at most the value (the ball's diameter); columns ox,oy,oz.
TEST(CliTest, SphereWritesOppositePointsWithinItsDiameter) {
  const std::string csv = Tmp("sphere.csv");
  const CliRun r = RunCli("sdf " + SharedMesh("decimated-knight.off") +
                          " --method sphere --opposite --csv " + csv);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("inscribed ball, contact cone 60 deg"));
  EXPECT_THAT(r.out, HasSubstr("502 ok"));
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "vertex,x,y,z,sdf,normalized,hits,kept,status,ox,oy,oz");
  int rows = 0;
  for (std::string line; std::getline(in, line); ++rows) {
    const std::vector<std::string> f = absl::StrSplit(line, ',');
    ASSERT_EQ(f.size(), 12u) << line;
    const Vec3 x(std::stod(f[1]), std::stod(f[2]), std::stod(f[3]));
    const Vec3 q(std::stod(f[9]), std::stod(f[10]), std::stod(f[11]));
    const double value = std::stod(f[4]);
    EXPECT_GT(Norm(q - x), 0) << line;
    EXPECT_LE(Norm(q - x), value * (1 + 1e-12)) << line;
  }
  EXPECT_EQ(rows, 502);
  const CliRun bad = RunCli("sdf " + SharedMesh("decimated-knight.off") +
                            " --method sphere --contact-angle 90");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.out, HasSubstr("--contact-angle"));
  std::filesystem::remove(csv);
}

// The segment file holds, in double precision, exactly the CSV's vertex,
// opposite point and value of every vertex with a value, and nothing else.
TEST(CliTest, OppositePlyIsTheCsvsSegmentsBitForBit) {
  const std::string csv = Tmp("segments.csv"), ply = Tmp("segments.ply");
  const CliRun r = RunCli("sdf " + SharedMesh("decimated-knight.off") +
                          " --rays 16 --opposite-ply " + ply + " --csv " + csv);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  std::map<int32_t, std::vector<double>> rows;  // vertex -> x y z o q
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  ASSERT_THAT(line, HasSubstr(",ox,oy,oz"));  // --opposite-ply implies it.
  while (std::getline(in, line)) {
    const std::vector<std::string> f = absl::StrSplit(line, ',');
    if (f[8] != "OK") continue;
    rows[std::stoi(f[0])] = {
        std::stod(f[1]),  std::stod(f[2]),  std::stod(f[3]), std::stod(f[9]),
        std::stod(f[10]), std::stod(f[11]), std::stod(f[4])};
  }
  ASSERT_GT(rows.size(), 400u);
  std::ifstream bin(ply, std::ios::binary);
  std::string header;
  for (std::getline(bin, line); line != "end_header"; std::getline(bin, line)) {
    ASSERT_TRUE(bin) << header;
    header += line + "\n";
  }
  EXPECT_THAT(header, HasSubstr("element vertex " +
                                std::to_string(2 * rows.size()) + "\n"));
  EXPECT_THAT(header,
              HasSubstr("element edge " + std::to_string(rows.size()) + "\n"));
  EXPECT_THAT(header, HasSubstr("property double x\n"));
  struct Point {
    double x, y, z, quality;
    int32_t sample;
  };
  std::vector<Point> points(2 * rows.size());
  for (Point& p : points) {
    bin.read(reinterpret_cast<char*>(&p), 4 * sizeof(double));
    bin.read(reinterpret_cast<char*>(&p.sample), sizeof(int32_t));
  }
  const size_t edges = rows.size();
  for (size_t e = 0; e < edges; ++e) {
    int32_t ends[2];
    bin.read(reinterpret_cast<char*>(ends), sizeof(ends));
    ASSERT_TRUE(bin);
    const Point& a = points[ends[0]];
    const Point& b = points[ends[1]];
    ASSERT_EQ(a.sample, b.sample);
    ASSERT_EQ(rows.count(a.sample), 1u) << a.sample;
    const std::vector<double>& row = rows[a.sample];
    EXPECT_EQ(std::vector<double>({a.x, a.y, a.z, b.x, b.y, b.z, a.quality}),
              row);
    EXPECT_EQ(b.quality, a.quality);
    rows.erase(a.sample);
  }
  EXPECT_TRUE(rows.empty());
  bin.peek();
  EXPECT_TRUE(bin.eof());
  std::filesystem::remove(csv);
  std::filesystem::remove(ply);
}

// Face samples (SPEC v2 §5c): one CSV row per face at its centroid, the
// values per face in the PLY's face quality, the weights of grad one per
// face; the verbs integrating vertex values do not take the flag.
TEST(CliTest, FaceSamplesGiveOneValuePerFace) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const std::string csv = Tmp("faces.csv"), ply = Tmp("faces.ply");
  const CliRun r = RunCli("sdf " + knight + " --samples faces --method " +
                          "normal --json --csv " + csv + " --ply " + ply);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["samples"], "faces");
  EXPECT_EQ(j["ok"].get<int64_t>() + j["no_hit"].get<int64_t>(), 1000);
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "face,x,y,z,sdf,normalized,hits,kept,status");
  // Each row is at its face's centroid; the PLY holds its value as the
  // face's quality.
  auto mesh = ReadMesh(knight);
  ASSERT_TRUE(mesh.ok());
  std::vector<double> sdf;
  for (int f = 0; std::getline(in, line); ++f) {
    const std::vector<std::string> c = absl::StrSplit(line, ',');
    ASSERT_EQ(c.size(), 9u) << line;
    const Face& face = mesh->faces[f];
    const Vec3 centroid =
        (mesh->positions[face.v[0]] + mesh->positions[face.v[1]] +
         mesh->positions[face.v[2]]) /
        3;
    EXPECT_EQ(Vec3(std::stod(c[1]), std::stod(c[2]), std::stod(c[3])), centroid)
        << line;
    sdf.push_back(c[8] == "OK" ? std::stod(c[4]) : std::nan(""));
  }
  ASSERT_EQ(sdf.size(), 1000u);
  const std::string bytes = Slurp(ply);
  const std::string end = "end_header\n";
  const size_t body = bytes.find(end) + end.size();
  EXPECT_THAT(bytes.substr(0, body),
              HasSubstr("element face 1000\nproperty list uchar int "
                        "vertex_indices\nproperty float quality\n"));
  const size_t faces = body + 502 * 3 * sizeof(float);
  const size_t record = 1 + 3 * sizeof(int32_t) + sizeof(float);
  ASSERT_EQ(bytes.size(), faces + 1000 * record);
  for (int f = 0; f < 1000; ++f) {
    float quality;
    std::memcpy(&quality, bytes.data() + faces + f * record + 13,
                sizeof(float));
    EXPECT_TRUE(quality == static_cast<float>(sdf[f]) ||
                (std::isnan(quality) && std::isnan(sdf[f])))
        << "face " << f;
  }
  const std::string weights = Tmp("vertex_weights.txt");
  {
    std::ofstream w(weights);
    for (int i = 0; i < 502; ++i) w << "1\n";
  }
  const CliRun wrong = RunCli("grad " + knight +
                              " --samples faces --rays 8 --weights " + weights);
  EXPECT_NE(wrong.exit_code, 0);
  EXPECT_THAT(wrong.out, HasSubstr("502 weights but the mesh has 1000 faces"));
  // The penalty of face samples integrates each face's own value.
  const CliRun penalty =
      RunCli("penalty " + knight + " --samples faces --t-min 0.1 --json");
  EXPECT_EQ(penalty.exit_code, 0) << penalty.out;
  EXPECT_THAT(penalty.out, HasSubstr("\"samples\":\"faces\""));
  // gradcheck: --samples names the set, or (its older meaning) a count,
  // which --probes may not contradict.
  const CliRun both =
      RunCli("gradcheck " + knight + " --rays 8 --probes 3 --samples 4");
  EXPECT_EQ(both.exit_code, 1);
  EXPECT_THAT(both.out, HasSubstr("not both"));
  const CliRun hex = RunCli("gradcheck " + knight + " --samples 0x10");
  EXPECT_EQ(hex.exit_code, 2);
  EXPECT_THAT(hex.out, HasSubstr("--samples"));
  std::filesystem::remove(csv);
  std::filesystem::remove(ply);
  std::filesystem::remove(weights);
}

TEST(CliTest, HorseWarnsAndReorientsOnRequest) {
  const CliRun warn = RunCli("sdf " + SharedMesh("horse.ply") + " --rays 4");
  ASSERT_EQ(warn.exit_code, 0);
  EXPECT_THAT(warn.out, HasSubstr("negative signed volume"));
  const CliRun fixed =
      RunCli("sdf " + SharedMesh("horse.ply") + " --rays 4 --reorient --json");
  ASSERT_EQ(fixed.exit_code, 0) << fixed.out;
  const auto j = nlohmann::json::parse(fixed.out);
  EXPECT_EQ(j["reoriented_components"], 1);
  EXPECT_EQ(j["inward_components"].size(), 0u);
  // Reoriented, the cones look into the solid: almost every vertex hits.
  EXPECT_GT(j["ok"].get<int64_t>(), 48000);
}

TEST(CliTest, SummaryNamesInwardComponentsAndPolygons) {
  // Two cubes written as quads and one hexagon-capped prism; the second
  // cube is inside out.
  const std::string obj = Tmp("two_bodies.obj");
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                        "v 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                        "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\n"
                        "f 3 4 8 7\nf 4 1 5 8\n"
                        "v 3 0 0\nv 4 0 0\nv 4 1 0\nv 3 1 0\n"
                        "v 3 0 1\nv 4 0 1\nv 4 1 1\nv 3 1 1\n"
                        "f 9 10 11 12\nf 13 16 15 14\nf 9 13 14 10\n"
                        "f 10 14 15 11\nf 11 15 16 12\nf 12 16 13 9\n";
  const CliRun r = RunCli("sdf " + obj + " --rays 8 --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["components"], 2);
  EXPECT_EQ(j["inward_components"], nlohmann::json::array({1}));
  EXPECT_THAT(r.out, HasSubstr("1 of 2 components are closed and turned inside out"));
  const CliRun fixed = RunCli("sdf " + obj + " --rays 8 --json --reorient");
  const auto k = nlohmann::json::parse(fixed.out);
  EXPECT_EQ(k["reoriented_components"], 1);
  EXPECT_EQ(k["inward_components"].size(), 0u);
  EXPECT_EQ(k["no_hit"], 0);
  std::filesystem::remove(obj);
}

TEST(CliTest, DegenerateFacesAreRejectedUnlessDroppingIsAsked) {
  const std::string obj = Tmp("degenerate.obj");
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 2 0 0\n"
                        "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\nf 1 2 5\n";
  const CliRun r = RunCli("sdf " + obj + " --rays 8");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.out, HasSubstr("1 faces have zero area (first face ids: 4)"));
  EXPECT_THAT(r.out, HasSubstr("--drop-degenerate-faces"));
  const CliRun d =
      RunCli("sdf " + obj + " --rays 8 --drop-degenerate-faces --json");
  ASSERT_EQ(d.exit_code, 0) << d.out;
  const auto j = nlohmann::json::parse(d.out);
  EXPECT_EQ(j["dropped_degenerate_faces"], 1);
  EXPECT_EQ(j["faces"], 4);
  EXPECT_EQ(j["vertices"], 5);  // nothing renumbered.
  std::filesystem::remove(obj);
}

TEST(CliTest, DoubleSidedAndOpenMeshesAreNamed) {
  const std::string obj = Tmp("double.obj");
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 3 2\n";
  // Nothing can be measured: the summary, then the cause, exit 1.
  const CliRun r = RunCli("sdf " + obj + " --rays 8 --json", false);
  ASSERT_EQ(r.exit_code, 1) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["double_sided_faces"], 2);
  EXPECT_THAT(r.out, HasSubstr("double-sided"));
  EXPECT_THAT(RunCliStderr("sdf " + obj + " --rays 8").out,
              HasSubstr("error: no vertex has a value: most of those vertices "
                        "have a degenerate normal"));
  const CliRun open =
      RunCli("sdf " + SharedMesh("stanford-bunny.obj") + " --rays 4 --json");
  EXPECT_GT(nlohmann::json::parse(open.out)["boundary_edges"].get<int64_t>(),
            0);
  EXPECT_THAT(open.out, HasSubstr("the mesh is open"));
  std::filesystem::remove(obj);
}

TEST(CliTest, TwoDimensionalHollowShapeWithRegionDirections) {
  const std::string obj = Tmp("hollow.obj");
  ASSERT_EQ(
      RunCli("shape hollow --radius 1 --size 0.05 --out " + obj).exit_code, 0);
  const CliRun r = RunCli(
      "sdf " + obj + " --method normal --region-direction 1=outward --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["dimension"], 2);
  EXPECT_EQ(j["no_hit"], 0);
  const CliRun bad = RunCli("sdf " + obj + " --region-direction 1=sideways");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.out,
              HasSubstr("--region-direction expects ID=inward|outward"));
  std::filesystem::remove(obj);
}

TEST(CliTest, HelpListsEachVerbsOwnFlagsAndExitsZero) {
  const CliRun top = RunCli("--help");
  EXPECT_EQ(top.exit_code, 0);
  for (const char* verb : {"sdf", "grad", "penalty", "calibrate", "report",
                           "gradcheck", "shape", "remote"}) {
    EXPECT_THAT(top.out, HasSubstr(verb));
  }
  const CliRun sdf = RunCli("sdf --help");
  EXPECT_EQ(sdf.exit_code, 0);
  EXPECT_THAT(sdf.out, HasSubstr("--cone-angle"));
  EXPECT_THAT(sdf.out, HasSubstr("--csv"));
  EXPECT_THAT(sdf.out, Not(HasSubstr("--bins")));   // calibrate's.
  EXPECT_THAT(sdf.out, Not(HasSubstr("--t-min")));  // penalty's.
  const CliRun pen = RunCli("penalty --help");
  EXPECT_THAT(pen.out, HasSubstr("--rho"));
  EXPECT_THAT(pen.out, Not(HasSubstr("--csv")));
  const CliRun remote_sdf = RunCli("remote sdf --help");
  EXPECT_EQ(remote_sdf.exit_code, 0);
  EXPECT_THAT(remote_sdf.out, HasSubstr("--method"));
  EXPECT_THAT(remote_sdf.out, HasSubstr("--ply"));  // the local verb's files.
  EXPECT_THAT(remote_sdf.out, HasSubstr("--session-id"));
  EXPECT_THAT(remote_sdf.out, HasSubstr("--server"));  // after the verb too.
  EXPECT_THAT(remote_sdf.out, HasSubstr("--token-file"));
  EXPECT_THAT(sdf.out, Not(HasSubstr("--server")));  // local only.
}

TEST(CliTest, VersionNamesTheProjectVersionAndBuildType) {
  const CliRun v = RunCli("--version");
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_THAT(v.out, HasSubstr("meshgauge 0."));
  EXPECT_THAT(v.out, HasSubstr("build)"));
  EXPECT_THAT(v.out, Not(HasSubstr("NDEBUG")));
}

TEST(CliTest, EveryFlagTheReadmeNamesExists) {
  std::ifstream readme(std::string(MESHGAUGE_SOURCE_DIR) + "/README.md");
  const std::string text((std::istreambuf_iterator<char>(readme)), {});
  const size_t begin = text.find("## The `meshgauge` CLI");
  const size_t end = text.find("\n## ", begin + 1);
  ASSERT_NE(begin, std::string::npos);
  const std::string section = text.substr(begin, end - begin);
  CliRun all = RunCli("--help-all");
  ASSERT_EQ(all.exit_code, 0);
  all.out += RunCli("remote --help-all").out;  // the remote verbs' own.
  std::set<std::string> flags;
  for (size_t i = section.find("--"); i != std::string::npos;
       i = section.find("--", i + 2)) {
    size_t j = i + 2;
    while (j < section.size() &&
           (std::islower(static_cast<unsigned char>(section[j])) ||
            section[j] == '-')) {
      ++j;
    }
    if (j - i > 3) flags.insert(section.substr(i, j - i));
  }
  EXPECT_GT(flags.size(), 20u);
  for (const std::string& flag : flags) {
    EXPECT_THAT(all.out, HasSubstr(flag + " ")) << "README names " << flag;
  }
}

TEST(CliTest, PreciseErrors) {
  struct Case {
    std::string args, message;
    int exit_code;
  };
  const std::string knight = SharedMesh("decimated-knight.off");
  for (const Case& c : std::vector<Case>{
           // Runtime errors: 1.
           {"sdf /nonexistent.obj", "cannot open mesh file '/nonexistent.obj'",
            1},
           // Usage errors: 2, out-of-range numbers included.
           {"sdf " + knight + " --cone-angle 200",
            "--cone-angle: Value 200 not in (0, 180)", 2},
           {"sdf " + knight + " --cone-angle 180", "not in (0, 180)", 2},
           {"sdf " + knight + " --kappa -1", "--kappa: Value -1 not in [0", 2},
           {"penalty " + knight + " --t-min 0", "--t-min: Value 0 not in (0",
            2},
           {"penalty " + knight + " --t-min 1 --max-missing-fraction 2",
            "--max-missing-fraction: Value 2 not in [0, 1]", 2},
           {"calibrate " + knight + " --t-min nan", "--t-min: Value nan", 2},
           {"sdf " + knight + " --rays 5000",
            "--rays: Value 5000 not in range 1 to 4096", 2},
           {"sdf " + knight + " --rays 0", "not in range 1 to 4096", 2},
           {"sdf " + knight + " --rays abc", "--rays", 2},
           {"sdf " + knight + " --method foo", "--method: foo not in", 2},
           {"sdf", "mesh is required", 2},
           {"sdf " + knight + " " + knight, "not expected", 2},
           {"sdf " + knight + " --bins 5", "not expected", 2},
           {"sdf " + knight + " --no-such-flag", "not expected", 2},
           {"shape sphere", "--out is required", 2},
           {"penalty " + knight, "--t-min is required", 2},
           {"frobnicate",
            "unknown verb 'frobnicate' (verbs: sdf, grad, penalty, calibrate, "
            "report, gradcheck, shape, remote)",
            2},
           {"remote frob", "unknown verb 'frob' (verbs: sdf, grad", 2}}) {
    const CliRun r = RunCli(c.args);
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << "\n" << r.out;
    EXPECT_THAT(r.out, HasSubstr(c.message)) << c.args;
  }
  const std::string bad = Tmp("bad.obj");
  std::ofstream(bad) << "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n";
  const CliRun r = RunCli("sdf " + bad);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.out, HasSubstr("1 faces have zero area (first face ids: 0)"));
  std::filesystem::remove(bad);
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

TEST(CliDerivativesTest, GradWritesVjpAndJacobian) {
  const std::string vjp = Tmp("vjp.csv"), jac = Tmp("jac.csv"),
                    w = Tmp("w.txt");
  {
    std::ofstream out(w);
    for (int i = 0; i < 502; ++i) out << (i % 3) << "\n";
  }
  const CliRun r = RunCli("grad " + SharedMesh("decimated-knight.off") +
                          " --rays 20 --weights " + w + " --vjp " + vjp +
                          " --jacobian " + jac + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["jacobian_nonzeros"].get<int64_t>(), 502);
  std::ifstream in(vjp);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, "vertex,dx,dy,dz");
  std::ifstream jin(jac);
  std::getline(jin, header);
  EXPECT_EQ(header, "row,col,dx,dy,dz");
  const CliRun bad = RunCli("grad " + SharedMesh("decimated-knight.off") +
                            " --weights " + SharedMesh("README.md"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.out, HasSubstr("not a finite number"));
  for (const auto& f : {vjp, jac, w}) std::filesystem::remove(f);
}

TEST(CliDerivativesTest, PenaltyPrintsValueAndWritesGradient) {
  const std::string grad = Tmp("pgrad.csv");
  const CliRun r = RunCli("penalty " + SharedMesh("decimated-knight.off") +
                          " --t-min 0.1 --rays 20 --json --grad " + grad);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["penalty"].get<double>(), 0);
  EXPECT_EQ(j["form"], "one-sided");
  EXPECT_EQ(j["missing_vertices"], 0);
  EXPECT_EQ(j["missing_area_fraction"], 0.0);
  EXPECT_EQ(j["world_frame_vertices"], 0);
  int lines = 0;
  std::ifstream in(grad);
  for (std::string l; std::getline(in, l);) ++lines;
  EXPECT_EQ(lines, 503);
  const CliRun no_tmin =
      RunCli("penalty " + SharedMesh("decimated-knight.off"));
  EXPECT_EQ(no_tmin.exit_code, 2);
  EXPECT_THAT(no_tmin.out, HasSubstr("--t-min is required"));
  const CliRun bad_phi = RunCli(
      "penalty " + SharedMesh("decimated-knight.off") + " --t-min 1 --form x");
  EXPECT_EQ(bad_phi.exit_code, 2);
  EXPECT_THAT(bad_phi.out, HasSubstr("--form: x not in {one-sided,thesis,ks}"));
  std::filesystem::remove(grad);
}

TEST(CliDerivativesTest, KsConstraintFormPrintsConstraint) {
  const CliRun r = RunCli("penalty " + SharedMesh("decimated-knight.off") +
                          " --t-min 0.3 --form ks --rho 30 --rays 20 --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["form"], "ks");
  EXPECT_EQ(j["rho"], 30.0);
  EXPECT_LT(j["constraint"].get<double>(), 1.0);
  const CliRun text = RunCli("penalty " + SharedMesh("decimated-knight.off") +
                             " --t-min 0.3 --form ks --rays 20");
  EXPECT_THAT(text.out, HasSubstr("constraint G = "));
}

TEST(CliDerivativesTest, PenaltyOnMostlyMissingValuesFailsNamingTheCause) {
  // The shared horse is inward oriented: most cones look outside.
  const CliRun r =
      RunCli("penalty " + SharedMesh("horse.ply") + " --t-min 0.01 --rays 10");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.out, HasSubstr("mostly missing"));
  EXPECT_THAT(r.out, HasSubstr("reorient"));
  const CliRun sdf = RunCli("sdf " + SharedMesh("horse.ply") + " --rays 10");
  EXPECT_EQ(sdf.exit_code, 0);
  EXPECT_THAT(sdf.out, HasSubstr("warning: "));
  EXPECT_THAT(sdf.out, HasSubstr("of its area (94.6% of the mesh's) has no "
                                 "value, 44984 vertices: it is closed and "
                                 "turned inside out"));
}

// Outsider report: grad wrote an all-zero gradient with exit 0 and report
// exited 0 on surfaces without values, where penalty fails: an optimiser or
// a CI check would read "converged" or "thick enough".
TEST(CliDerivativesTest, GradAndReportOnMostlyMissingValuesFailNamingTheCause) {
  const std::string horse = SharedMesh("horse.ply");  // inward oriented.
  const std::string vjp = Tmp("missing_vjp.csv");
  const CliRun grad = RunCli("grad " + horse + " --rays 10 --vjp " + vjp);
  EXPECT_EQ(grad.exit_code, 1) << grad.out;
  EXPECT_THAT(grad.out, HasSubstr("warning: component 0 (96966 faces)"));
  EXPECT_THAT(grad.out, HasSubstr("error: a gradient over a surface whose "
                                  "values are mostly missing"));
  EXPECT_FALSE(std::filesystem::exists(vjp));
  const CliRun allowed = RunCli(
      "grad " + horse + " --rays 10 --json --max-missing-fraction 1", false);
  ASSERT_EQ(allowed.exit_code, 0) << allowed.out;
  const auto j = nlohmann::json::parse(allowed.out);
  EXPECT_NEAR(j["missing_area_fraction"].get<double>(), 0.946, 1e-3);
  // The mesh's warning, then the pass's, as in `sdf --json`; and penalty's.
  ASSERT_EQ(j["warnings"].size(), 2u);
  EXPECT_THAT(j["warnings"][0].get<std::string>(),
              HasSubstr("1 of 1 components are closed and turned inside "
                        "out"));
  EXPECT_THAT(j["warnings"][1].get<std::string>(),
              HasSubstr("component 0 (96966 faces): 94.6% of its area"));
  const CliRun penalty = RunCli("penalty " + horse +
                                    " --t-min 0.01 --rays 10 --json "
                                    "--max-missing-fraction 1",
                                false);
  ASSERT_EQ(penalty.exit_code, 0) << penalty.out;
  EXPECT_EQ(nlohmann::json::parse(penalty.out)["warnings"], j["warnings"]);

  const std::filesystem::path dir = Tmp("missing_report");
  const CliRun report = RunCli("report " + horse +
                               " --t-min 0.01 --rays 10 --view-size 64 64 "
                               "--out " +
                               dir.string());
  EXPECT_EQ(report.exit_code, 1) << report.out;
  EXPECT_THAT(report.out, HasSubstr("error: a report (written to '" +
                                    dir.string() + "') over a surface"));
  EXPECT_TRUE(std::filesystem::exists(dir / "report.json"));
  EXPECT_EQ(RunCli("report " + horse +
                   " --t-min 0.01 --rays 10 --view-size 64 64 "
                   "--max-missing-fraction 1 --out " +
                   dir.string())
                .exit_code,
            0);
  std::filesystem::remove_all(dir);
}

TEST(CliDerivativesTest, GradcheckPassesOnKnightAndPrintsTable) {
  const CliRun r = RunCli("gradcheck " + SharedMesh("decimated-knight.off") +
                          " --rays 20 --samples 4 --seed 3 --t-min 0.3");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_THAT(r.out, HasSubstr("analytic"));
  EXPECT_THAT(r.out, HasSubstr("   g^T J "));  // each VJP check's row.
  EXPECT_THAT(r.out, HasSubstr("verdict: PASS"));
  const CliRun json = RunCli("gradcheck " + SharedMesh("decimated-knight.off") +
                             " --rays 20 --samples 2 --json");
  EXPECT_EQ(json.exit_code, 0) << json.out;
  EXPECT_TRUE(nlohmann::json::parse(json.out)["passed"].get<bool>());
}

TEST(CliDerivativesTest, GradcheckFailsWhenTheToleranceCannotBeMet) {
  // A tolerance below the round-off of central differences must fail.
  const CliRun r = RunCli("gradcheck " + SharedMesh("decimated-knight.off") +
                          " --rays 20 --samples 3 --fd-tolerance 1e-15");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_THAT(r.out, HasSubstr("verdict: FAIL"));
}

TEST(CliDerivativesTest, CalibrateReportsAlphas) {
  const CliRun r = RunCli("calibrate " + SharedMesh("1002_tray_bottom.STL") +
                          " --t-min 2 --json");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["compared"], 2216);
  EXPECT_EQ(j["sdf_lower"].get<int64_t>() + j["sdf_equal"].get<int64_t>() +
                j["sdf_higher"].get<int64_t>(),
            2216);
  EXPECT_GT(j["alpha1"].get<double>(), 3.175 / 2);
  EXPECT_EQ(j["sdf_histogram"].size(), 20u);
}

}  // namespace
}  // namespace meshgauge

namespace meshgauge {
namespace {

TEST(CliReportTest, WritesThePicturesTheTableThePageAndTheColouredPly) {
  const std::filesystem::path dir = Tmp("report");
  const CliRun r = RunCli("report " + SharedMesh("decimated-knight.off") +
                              " --t-min 0.1 --rays 20 --view-size 160 120 "
                              "--min-region-area 0.001 --out " +
                              dir.string(),
                          false);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_THAT(r.out, ::testing::ContainsRegex(
                         "^[0-9.]+ % of the surface \\(area [0-9.e-]+ of "
                         "[0-9.e-]+\\) is thinner than 0.1; thinnest "
                         "[0-9.e-]+ at \\(.*\\)\n$"));
  const auto j = nlohmann::json::parse(Slurp(dir / "report.json"));
  EXPECT_EQ(j["sentence"].get<std::string>() + "\n", r.out);
  const auto& regions = j["thin"]["regions"];
  ASSERT_GT(regions.size(), 1u);
  for (size_t i = 1; i < regions.size(); ++i) {
    EXPECT_GE(regions[i - 1]["area"].get<double>(),
              regions[i]["area"].get<double>());
    EXPECT_EQ(regions[i]["speck"].get<bool>(),
              regions[i]["area"].get<double>() < 0.001);
  }
  double binned = 0;
  for (double a : j["histogram"]["area"]) binned += a;
  EXPECT_NEAR(binned,
              j["thin"]["total_area"].get<double>() -
                  j["thin"]["missing_area"].get<double>(),
              1e-9 * binned);
  EXPECT_EQ(j["parameters"]["t_min"], 0.1);
  EXPECT_EQ(j["parameters"]["rays_per_vertex"], 20);
  auto views = ReadPng((dir / "views.png").string());
  ASSERT_TRUE(views.ok()) << views.status();
  EXPECT_EQ(views->width, 2 * (160 + 8) + 210);
  EXPECT_EQ(views->height, std::max(2 * (24 + 120 + 8), 320));  // bar room.
  auto histogram = ReadPng((dir / "histogram.png").string());
  ASSERT_TRUE(histogram.ok()) << histogram.status();
  const std::string ply = Slurp(dir / "colored.ply");
  EXPECT_THAT(ply, HasSubstr("property float quality\nproperty uchar red\n"));
  const std::string html = Slurp(dir / "index.html");
  EXPECT_THAT(html, HasSubstr("src=\"data:image/png;base64,"));
  EXPECT_THAT(html, HasSubstr("<h2>Thin regions</h2>"));
  EXPECT_THAT(html, HasSubstr("<h2>Missing values</h2>"));
  // Nothing from the network: no src/href to an address (the http strings
  // of the embedded three.js are checked in tests/report_page_test.cc).
  EXPECT_THAT(html, Not(HasSubstr("src=\"http")));
  EXPECT_THAT(html, Not(HasSubstr("href=\"http")));
  EXPECT_THAT(html, Not(HasSubstr("url(http")));
  std::filesystem::remove_all(dir);
}

// A CAD export (trimesh's 1002_tray_bottom, a uniform 3.175 mm sheet of
// long triangles): its vertices sit on sharp edges, where the inscribed
// ball is small, so vertex samples call a quarter of it thin; face samples
// (each face's centroid along its own normal) measure the sheet.
TEST(CliReportTest, FaceSamplesMeasureACadSheet) {
  const std::string tray = SharedMesh("1002_tray_bottom.STL");
  const std::string out = Tmp("tray_report");
  const CliRun faces = RunCli("report " + tray +
                              " --method sphere --samples faces --t-min 3 "
                              "--json --out " +
                              out);
  ASSERT_EQ(faces.exit_code, 0) << faces.out;
  const auto j = nlohmann::json::parse(Slurp(out + "/report.json"));
  EXPECT_LT(j["thin"]["thin_fraction"].get<double>(), 0.05);
  EXPECT_EQ(j["summary"]["samples"], "faces");
  EXPECT_TRUE(j["thin"]["thinnest"].contains("face"));
  const CliRun penalty = RunCli("penalty " + tray +
                                " --method sphere --samples faces --t-min 3 "
                                "--json");
  ASSERT_EQ(penalty.exit_code, 0) << penalty.out;
  const auto p = nlohmann::json::parse(penalty.out);
  EXPECT_NEAR(p["thin"]["thin_fraction"].get<double>(),
              j["thin"]["thin_fraction"].get<double>(), 1e-12);
  const CliRun vertices = RunCli("penalty " + tray +
                                 " --method sphere --t-min 3 --json");
  ASSERT_EQ(vertices.exit_code, 0) << vertices.out;
  EXPECT_GT(nlohmann::json::parse(vertices.out)["thin"]["thin_fraction"]
                .get<double>(),
            0.2);
}

TEST(CliReportTest, PenaltyAnswersWhereAndHowMuch) {
  const CliRun r = RunCli("penalty " + SharedMesh("decimated-knight.off") +
                          " --t-min 0.1 --rays 20");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_THAT(r.out, ::testing::ContainsRegex(
                         "% of the surface \\(area .* of .*\\) is thinner "
                         "than 0.1; thinnest .* at \\("));
}

TEST(CliReportTest, RejectsBadFlagsAndAnOutPathThatIsAFile) {
  const std::string knight = SharedMesh("decimated-knight.off");
  const std::string file = Tmp("not_a_dir");
  std::ofstream(file) << "x";
  struct Case {
    std::string args, message;
    int exit_code;
  };
  for (const Case& c : std::vector<Case>{
           {"report " + knight + " --out " + Tmp("r1"), "--t-min is required",
            2},
           {"report " + knight + " --t-min 1", "--out is required", 2},
           {"report " + knight + " --t-min 1 --out x --up w", "--up", 2},
           {"report " + knight + " --t-min 1 --out x --view-size 8 8",
            "--view-size", 2},
           {"report " + knight + " --t-min -1 --out " + Tmp("r2"),
            "--t-min: Value -1 not in (0, inf)", 2},
           {"report " + knight + " --t-min 1 --min-region-area -2 --out " +
                Tmp("r3"),
            "--min-region-area: Value -2 not in [0, inf)", 2},
           {"report " + knight + " --t-min 1 --color-range 0 inf --out " +
                Tmp("r3"),
            "--color-range: Value inf", 2},
           {"report " + knight + " --t-min 1 --color-range 2 1 --out " +
                Tmp("r4"),
            "--color-range", 1},
           {"report " + knight + " --t-min 1 --out " + file,
            "is not a directory", 1}}) {
    const CliRun r = RunCli(c.args);
    EXPECT_EQ(r.exit_code, c.exit_code) << c.args << "\n" << r.out;
    EXPECT_THAT(r.out, HasSubstr(c.message)) << c.args;
  }
  for (const char* d : {"r1", "r2", "r3", "r4"}) {
    std::filesystem::remove_all(Tmp(d));
  }
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace meshgauge
