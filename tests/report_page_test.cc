// index.html of `meshgauge report` in a real browser: headless Chromium
// (Debian's `chromium`, installed by scripts/install_deps.sh) renders the
// page with no console message, and its screenshot shows the embedded
// pictures (the map's colours and the red thin-region outlines) and the
// interactive view (three.js in WebGL, software-rendered by SwiftShader);
// the page's self-test (index.html#selftest=T1,T2) moves the t_min slider
// and clicks a region row, and its thin share equals the CLI's for those
// t_min. Skipped, saying why, where no Chromium is installed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <regex>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "client/cli/report_viewer.h"
#include "client/cli/thin_summary.h"
#include "lib/core/colormap.h"
#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"
#include "lib/io/png_file.h"
#include "tests/cli_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

using testing::Slurp;
using ::testing::HasSubstr;
using testing::RunCli;
using testing::SharedMesh;
using testing::Tmp;

// $MESHGAUGE_CHROMIUM, or chromium / chromium-browser / google-chrome on
// PATH; empty when none.
std::string FindChromium() {
  if (const char* env = std::getenv("MESHGAUGE_CHROMIUM")) return env;
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "";
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    size_t begin = 0;
    while (begin <= dirs.size()) {
      const size_t end = std::min(dirs.find(':', begin), dirs.size());
      const std::filesystem::path candidate =
          std::filesystem::path(dirs.substr(begin, end - begin)) / name;
      if (std::filesystem::exists(candidate)) return candidate.string();
      begin = end + 1;
    }
  }
  return "";
}

// Runs headless Chromium on DIR/index.html (URL fragment `hash`) with
// WebGL in software, stdout and stderr into `log`; its exit code.
int Chromium(const std::string& chromium, const std::filesystem::path& dir,
             const std::string& args, const std::string& hash,
             const std::filesystem::path& log,
             const std::filesystem::path& out = "") {
  std::filesystem::remove_all(dir / "profile");
  const std::string cmd =
      "timeout 120 " + chromium +
      " --headless --no-sandbox --disable-gpu --use-angle=swiftshader "
      "--enable-unsafe-swiftshader --disable-background-networking "
      "--no-first-run --user-data-dir=" +
      (dir / "profile").string() + " --enable-logging=stderr --v=0 " + args +
      " 'file://" + std::filesystem::absolute(dir / "index.html").string() +
      hash + "' >" + (out.empty() ? log.string() : out.string()) + " 2>" +
      (out.empty() ? "&1" : log.string());
  const int status = std::system(cmd.c_str());
  EXPECT_EQ(status, 0) << cmd;
  return status;
}

// The page's console messages in Chromium's log, but for SwiftShader's
// "GL Driver Message ... GPU stall due to ReadPixels" (the browser reading
// the canvas for the screenshot, not the page).
std::string ConsoleLines(const std::filesystem::path& log) {
  std::ifstream in(log);
  std::string console;
  for (std::string line; std::getline(in, line);) {
    if (line.find(":CONSOLE") != std::string::npos &&
        line.find("GL Driver Message") == std::string::npos) {
      console += line + "\n";
    }
  }
  return console;
}

TEST(ReportPageTest, RendersInHeadlessChromiumWithNoConsoleMessage) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    GTEST_SKIP() << "no chromium on PATH (scripts/install_deps.sh installs "
                    "Debian's chromium); the page was not opened";
  }
  const std::filesystem::path dir = Tmp("page");
  const auto report = RunCli("report " + SharedMesh("rocker-arm.obj") +
                             " --t-min 0.08 --rays 20 --view-size 300 240 "
                             "--out " +
                             dir.string());
  ASSERT_EQ(report.exit_code, 0) << report.out;
  const std::filesystem::path shot = dir / "screenshot.png";
  const std::filesystem::path log = dir / "chromium.log";
  ASSERT_EQ(Chromium(chromium, dir, "--window-size=1000,1400 --screenshot=" +
                                        shot.string(),
                     "", log),
            0);
  EXPECT_EQ(ConsoleLines(log), "") << "the page logged to the console";
  auto image = ReadPng(shot.string());
  ASSERT_TRUE(image.ok()) << image.status();
  std::set<uint32_t> colours;
  int outline = 0;
  for (const Rgb& p : image->pixels) {
    colours.insert(p.r << 16 | p.g << 8 | p.b);
    outline += p == kThinOutline;
  }
  EXPECT_GT(colours.size(), 500u) << "a blank or text-only screenshot";
  EXPECT_GT(outline, 50) << "no thin-region outline: the views did not show";
  std::filesystem::remove_all(dir);
}


int Count(const Image& image, Rgb colour) {
  return static_cast<int>(
      std::count(image.pixels.begin(), image.pixels.end(), colour));
}

// A 60 x 40 plate 6 thick, t_min 2: the colours span 0..4 (t_min in the
// middle), the plate's 6 shows in the overflow colour, named in the legend
// and in report.json; --color-range still sets the range.
TEST(ReportColoursTest, TheDefaultRangeIsZeroToTwiceTMinWithOverflowAbove) {
  const std::filesystem::path dir = Tmp("colours");
  std::filesystem::create_directories(dir);
  const std::string plate = (dir / "plate.obj").string();
  ASSERT_TRUE(WriteObj(plate, MakeBox(60, 40, 6, 3)).ok());
  const auto report = RunCli("report " + plate +
                             " --t-min 2 --rays 20 --view-size 160 120 --out " +
                             (dir / "default").string());
  ASSERT_EQ(report.exit_code, 0) << report.out;
  auto j = nlohmann::json::parse(Slurp(dir / "default" / "report.json"));
  ASSERT_TRUE(j.contains("color_range")) << j.dump(2);
  const nlohmann::json& range = j["color_range"];
  EXPECT_EQ(range["low"], 0.0);
  EXPECT_EQ(range["high"], 4.0);
  EXPECT_EQ(range["source"], "default");
  EXPECT_EQ(range["above_label"], "> 2 T_MIN");
  EXPECT_EQ(range["above_color"],
            (nlohmann::json{kOverflowColor.r, kOverflowColor.g,
                            kOverflowColor.b}));
  // Most of the plate is 6 thick: above the range.
  const double total = j["thin"]["total_area"].get<double>();
  EXPECT_GT(range["above_area"].get<double>(), 0.5 * total);
  EXPECT_LE(range["above_area"].get<double>(), total);
  EXPECT_EQ(j["histogram"]["lo"], 0.0);
  EXPECT_EQ(j["histogram"]["hi"], 4.0);
  auto views = ReadPng((dir / "default" / "views.png").string());
  ASSERT_TRUE(views.ok()) << views.status();
  // The top view's plate (Lambert 1) in the overflow colour, and its swatch.
  EXPECT_GT(Count(*views, kOverflowColor), 160 * 120 / 4);
  auto histogram = ReadPng((dir / "default" / "histogram.png").string());
  ASSERT_TRUE(histogram.ok()) << histogram.status();
  EXPECT_GT(Count(*histogram, kOverflowColor), 500);  // its own bar.
  EXPECT_THAT(Slurp(dir / "default" / "index.html"),
              HasSubstr("&gt; 2&middot;t_min"));

  const auto fixed = RunCli("report " + plate +
                            " --t-min 2 --rays 20 --view-size 160 120 "
                            "--color-range 1 100 --out " +
                            (dir / "fixed").string());
  ASSERT_EQ(fixed.exit_code, 0) << fixed.out;
  j = nlohmann::json::parse(Slurp(dir / "fixed" / "report.json"));
  EXPECT_EQ(j["color_range"]["low"], 1.0);
  EXPECT_EQ(j["color_range"]["high"], 100.0);
  EXPECT_EQ(j["color_range"]["source"], "--color-range");
  EXPECT_EQ(j["color_range"]["above_label"], "> 100");
  EXPECT_EQ(j["color_range"]["above_area"], 0.0);
  EXPECT_EQ(j["parameters"]["color_range"], (nlohmann::json{1.0, 100.0}));
  views = ReadPng((dir / "fixed" / "views.png").string());
  ASSERT_TRUE(views.ok()) << views.status();
  EXPECT_LE(Count(*views, kOverflowColor), 28 * 18);  // the swatch alone.
  std::filesystem::remove_all(dir);
}

// The thin share the CLI computes for t_min (`meshgauge penalty --json`).
double CliThinFraction(const std::string& mesh, const std::string& args,
                       double t_min) {
  char t[64];
  std::snprintf(t, sizeof t, "%.17g", t_min);
  const auto run = RunCli("penalty " + mesh + args + " --t-min " + t + " --json",
                          false);
  EXPECT_EQ(run.exit_code, 0) << run.out;
  return nlohmann::json::parse(run.out)["thin"]["thin_fraction"].get<double>();
}

// The http(s) addresses in `page` outside /* */ and <!-- --> comments, but
// for XML namespace names (three.js creates elements in the XHTML namespace;
// nothing is fetched from them) and the address in three.js's warning text.
std::vector<std::string> Addresses(std::string page) {
  page = std::regex_replace(page, std::regex(R"(/\*[^*]*\*+(?:[^/*][^*]*\*+)*/)"), "");
  page = std::regex_replace(page, std::regex("<!--[\\s\\S]*?-->"), "");
  std::vector<std::string> found;
  const std::regex url("https?://[^\"'\\s)<>]*");
  for (auto it = std::sregex_iterator(page.begin(), page.end(), url);
       it != std::sregex_iterator(); ++it) {
    const std::string a = it->str();
    if (a.rfind("http://www.w3.org/", 0) == 0) continue;
    if (a.rfind("https://discourse.threejs.org/", 0) == 0) continue;
    found.push_back(a);
  }
  return found;
}

// Pixels of `image` within 3 levels of some colour of the map.
int RampPixels(const Image& image) {
  std::set<uint32_t> ramp;
  for (int i = 0; i < 768; ++i) {
    const Rgb c = ThicknessColor(i / 767.0);
    for (int dr = -3; dr <= 3; ++dr) {
      for (int dg = -3; dg <= 3; ++dg) {
        for (int db = -3; db <= 3; ++db) {
          ramp.insert(uint32_t(std::clamp(c.r + dr, 0, 255)) << 16 |
                      uint32_t(std::clamp(c.g + dg, 0, 255)) << 8 |
                      uint32_t(std::clamp(c.b + db, 0, 255)));
        }
      }
    }
  }
  int n = 0;
  for (const Rgb& p : image.pixels) n += ramp.count(p.r << 16 | p.g << 8 | p.b);
  return n;
}

// The interactive view: a report of the rocker arm (vertex values, then
// face values) opened from file:// in headless Chromium. The screenshot's
// canvas shows the map's colours on a white background; the self-test sets
// t_min to 0.05 and 0.1 and its thin share equals `meshgauge penalty`'s for
// them (1e-9 relative), the bands add up, clicking region row 1 flies the
// camera to that region's centroid, and nothing is logged or thrown. The
// page names no address it could fetch.
void ExpectInteractiveView(const std::string& samples) {
  const std::string chromium = FindChromium();
  if (chromium.empty()) {
    GTEST_SKIP() << "no chromium on PATH (scripts/install_deps.sh installs "
                    "Debian's chromium); the page was not opened";
  }
  const std::filesystem::path dir = Tmp("view" + samples);
  const std::string mesh = SharedMesh("rocker-arm.obj");
  const std::string flags = " --rays 20 --samples " + samples;
  const auto report = RunCli("report " + mesh + flags +
                             " --t-min 0.08 --view-size 200 160 --out " +
                             dir.string());
  ASSERT_EQ(report.exit_code, 0) << report.out;
  const std::string page = Slurp(dir / "index.html");
  EXPECT_THAT(Addresses(page), ::testing::IsEmpty());
  EXPECT_THAT(page, HasSubstr("MIT License"));  // three.js's licence.

  const std::filesystem::path shot = dir / "view.png";
  ASSERT_EQ(Chromium(chromium, dir, "--window-size=1000,800 --screenshot=" +
                                        shot.string(),
                     "", dir / "shot.log"),
            0);
  EXPECT_EQ(ConsoleLines(dir / "shot.log"), "");
  auto image = ReadPng(shot.string());
  ASSERT_TRUE(image.ok()) << image.status();
  // The canvas: 24..960 x 200..760 of the 1000 x 800 window.
  int painted = 0, total = 0;
  for (int y = 220; y < 740; ++y) {
    for (int x = 40; x < 940; ++x) {
      const Rgb& p = image->pixels[y * image->width + x];
      painted += !(p.r == 255 && p.g == 255 && p.b == 255);
      ++total;
    }
  }
  EXPECT_GT(painted, total / 20) << "the canvas shows nothing";
  EXPECT_GT(RampPixels(*image), 2000) << "no colour of the map in the view";

  ASSERT_EQ(Chromium(chromium, dir, "--window-size=1000,800 --dump-dom",
                     "#selftest=0.05,0.1", dir / "dom.log", dir / "dom.html"),
            0);
  EXPECT_EQ(ConsoleLines(dir / "dom.log"), "");
  const std::string dom = Slurp(dir / "dom.html");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(dom, m, std::regex("<pre id=\"mg-selftest\">(.*?)</pre>")))
      << dom.substr(0, 2000);
  const auto result = nlohmann::json::parse(m[1].str());
  EXPECT_EQ(result["webgl"], true);
  EXPECT_EQ(result["errors"], nlohmann::json::array()) << result.dump();
  ASSERT_EQ(result["steps"].size(), 2u);
  for (const nlohmann::json& step : result["steps"]) {
    const double t = step["t_min"].get<double>();
    const double cli = CliThinFraction(mesh, flags, t);
    EXPECT_NEAR(step["thin_fraction"].get<double>(), cli, 1e-9 * cli) << t;
    EXPECT_GT(cli, 0) << t;
    const nlohmann::json& b = step["bands"];
    EXPECT_NEAR(b["below"].get<double>() + b["within"].get<double>() +
                    b["above"].get<double>() + b["missing"].get<double>(),
                step["total_area"].get<double>(), 1e-12);
    EXPECT_THAT(step["answer"].get<std::string>(),
                HasSubstr(cli::Percent(cli) + " % of the surface"));
    EXPECT_GT(step["outline_points"].get<int>(), 0);
  }
  EXPECT_NE(result["steps"][0]["thin_fraction"], result["steps"][1]["thin_fraction"]);
  const auto j = nlohmann::json::parse(Slurp(dir / "report.json"));
  ASSERT_FALSE(j["thin"]["regions"].empty());
  EXPECT_EQ(result["clicked_row"], true);
  const nlohmann::json& target = result["camera_target"];
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(target[a].get<double>(),
                j["thin"]["regions"][0]["centroid"][a].get<double>(), 1e-9);
  }
  EXPECT_GT(result["canvas"]["painted"].get<int>(), 10000);
  EXPECT_GT(result["canvas"]["colours"].get<int>(), 100);
  std::filesystem::remove_all(dir);
}

TEST(ReportViewTest, VertexValuesInHeadlessChromium) {
  ExpectInteractiveView("vertices");
}

TEST(ReportViewTest, FaceValuesInHeadlessChromium) {
  ExpectInteractiveView("faces");
}

// report.json's bands: below t_min, [t_min, 1.1 t_min), above and without a
// value; they add up to the whole, the first is the thin area, and the page
// has their table.
TEST(ReportBandsTest, BandsAroundTMinAddUp) {
  for (const std::string samples : {"vertices", "faces"}) {
    const std::filesystem::path dir = Tmp("bands" + samples);
    const auto report = RunCli("report " + SharedMesh("rocker-arm.obj") +
                               " --rays 20 --samples " + samples +
                               " --t-min 0.08 --view-size 100 80 --out " +
                               dir.string());
    ASSERT_EQ(report.exit_code, 0) << report.out;
    const auto j = nlohmann::json::parse(Slurp(dir / "report.json"));
    ASSERT_TRUE(j.contains("bands")) << samples;
    const nlohmann::json& bands = j["bands"];
    ASSERT_EQ(bands.size(), 4u);
    EXPECT_EQ(bands[0]["band"], "below");
    EXPECT_EQ(bands[1]["band"], "within");
    EXPECT_EQ(bands[2]["band"], "above");
    EXPECT_EQ(bands[3]["band"], "no value");
    EXPECT_EQ(bands[0]["hi"], 0.08);
    EXPECT_EQ(bands[1]["lo"], 0.08);
    EXPECT_EQ(bands[1]["hi"], 0.08 * 1.1);
    EXPECT_EQ(bands[2]["lo"], 0.08 * 1.1);
    const double total = j["thin"]["total_area"].get<double>();
    double sum = 0, shares = 0;
    for (const nlohmann::json& b : bands) {
      sum += b["area"].get<double>();
      shares += b["share"].get<double>();
      EXPECT_GE(b["area"].get<double>(), 0) << b.dump();
    }
    EXPECT_NEAR(sum, total, 1e-12 * total) << samples;
    EXPECT_NEAR(shares, 1, 1e-12) << samples;
    EXPECT_NEAR(bands[0]["area"].get<double>(),
                j["thin"]["thin_area"].get<double>(), 1e-12 * total);
    EXPECT_GT(bands[1]["area"].get<double>(), 0) << samples;
    EXPECT_EQ(bands[3]["area"].get<double>(), j["thin"]["missing_area"]);
    const std::string page = Slurp(dir / "index.html");
    EXPECT_THAT(page, HasSubstr("<table id=\"mg-bands\">"));
    EXPECT_THAT(page, HasSubstr("within 10 % above t_min"));
    std::filesystem::remove_all(dir);
  }
}

// Above the limit the page sends a simplified copy: at most that many
// vertices, positions as 16-bit integers in the box, values as floats, and
// says so; at or below it, the mesh whole in doubles.
TEST(ReportViewTest, LargeMeshesAreSentSimplified) {
  const Mesh sphere = MakeIcosphere(1.0, 16);  // 2562 vertices.
  std::vector<double> values(sphere.num_vertices());
  for (int64_t i = 0; i < sphere.num_vertices(); ++i) values[i] = 0.01 * (i % 50);
  const nlohmann::json report = {
      {"thin", {{"t_min", 0.2}, {"regions", nlohmann::json::array()}}},
      {"parameters", {{"up", "z"}}},
      {"color_range",
       {{"low", 0}, {"high", 0.4}, {"source", "default"}, {"above_color", {1, 2, 3}}}}};
  const auto whole = cli::ViewerData(sphere, values, SampleSet::kVertices, report);
  EXPECT_EQ(whole["shown"]["decimated"], false);
  EXPECT_EQ(whole["shown"]["vertices"], sphere.num_vertices());
  EXPECT_EQ(whole["positions"]["dtype"], "f64");
  EXPECT_EQ(whole["values"]["dtype"], "f64");
  const auto small =
      cli::ViewerData(sphere, values, SampleSet::kVertices, report, 500);
  EXPECT_EQ(small["shown"]["decimated"], true);
  EXPECT_LE(small["shown"]["vertices"].get<int>(), 500);
  EXPECT_GT(small["shown"]["vertices"].get<int>(), 100);
  EXPECT_GT(small["shown"]["elements"].get<int>(), 200);
  EXPECT_EQ(small["positions"]["dtype"], "u16");
  EXPECT_EQ(small["values"]["dtype"], "f32");
  EXPECT_EQ(small["mesh"]["vertices"], sphere.num_vertices());
  std::vector<double> face_values(sphere.num_faces(), 0.3);
  const auto faces =
      cli::ViewerData(sphere, face_values, SampleSet::kFaces, report, 500);
  EXPECT_EQ(faces["samples"], "faces");
  EXPECT_LE(faces["shown"]["vertices"].get<int>(), 500);
  EXPECT_THAT(std::string(cli::web::kViewerScript),
              HasSubstr("the view shows a simplified copy"));
}

}  // namespace
}  // namespace meshgauge
