// index.html of `meshgauge report` in a real browser: headless Chromium
// (Debian's `chromium`, installed by scripts/install_deps.sh) renders the
// page with no console message, and its screenshot shows the embedded
// pictures (the map's colours and the red thin-region outlines). Skipped,
// saying why, where no Chromium is installed.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "lib/core/colormap.h"
#include "lib/core/shapes.h"
#include "lib/io/mesh_io.h"
#include "lib/io/png_file.h"
#include "tests/cli_test_util.h"
#include "tests/test_util.h"

namespace meshgauge {
namespace {

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
  const std::string cmd =
      chromium +
      " --headless --no-sandbox --disable-gpu --no-first-run "
      "--user-data-dir=" +
      (dir / "profile").string() +
      " --window-size=1000,1400 --enable-logging=stderr --v=0 "
      "--screenshot=" +
      shot.string() + " file://" +
      std::filesystem::absolute(dir / "index.html").string() + " >" +
      log.string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(log);
  std::string console;
  for (std::string line; std::getline(in, line);) {
    if (line.find(":CONSOLE") != std::string::npos) console += line + "\n";
  }
  EXPECT_EQ(console, "") << "the page logged to the console";
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

std::string Slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
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

}  // namespace
}  // namespace meshgauge
